"""App side of the workbench (no GUI imports): the parametric analysis object and what
macros call: make_analysis, export_analysis, probe_analysis, compare_analyses."""
from .analysis import (HullProdAnalysis, analyses_in, analysis_fields, is_analysis,  # noqa: F401
                       make_analysis, recompute_analysis, result_document, signature_of)
from .compare import compare_analyses  # noqa: F401
from .export import export_analysis, register_report_writer  # noqa: F401
from .probe import probe_analysis  # noqa: F401
