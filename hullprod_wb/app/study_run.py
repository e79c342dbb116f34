"""A verification study of an analysis object's source, run on what Analyze assessed.

The study takes the analysis's source object (sent to the assessment process exactly as
Analyze sends it), its faces, the L_ref it used (LrefUsed) and its tolerances and
quadrature settings, so that a study row at the analysis's h_f = k_f repeats the
analysis. No Qt here.
"""
import os
import re

from ..core.errors import InputError

#: Studies the assessment process runs (hullprod_wb.studies).
STUDY_KINDS = ("sameface", "refinement", "representation", "thresholds")
#: Studies that need a BRep source.
BREP_ONLY = ("sameface", "refinement", "representation")
QUADRATURE_KEYS = ("order", "rtol", "max_depth", "protocol", "point_budget", "depth_limit")


def study_settings(analysis):
    """(source object, faces or None, study options) of an analysis object: options
    lref (the L_ref used; None when the analysis has none), h_f, k_f and, for a BRep, the
    quadrature settings (app.analysis.assessment_options)."""
    from .analysis import assessment_options
    src = analysis.Source
    if src is None:
        raise InputError("the analysis %s has no source object" % analysis.Label)
    rep = "brep" if hasattr(src, "Shape") else "mesh"
    options = assessment_options(analysis, rep)
    used = analysis.LrefUsed
    options["lref"] = used if used == used and used > 0 else options["lref"]
    faces = list(analysis.FacesUsed) if rep == "brep" and analysis.SkipPlanarFaces else list(analysis.Faces)
    return src, (faces or None), options


def run_study(kind, source, faces, options, progress):
    """The study document of kind on source (a BRep file path or a mesh's (V, F)) with
    the options of study_settings."""
    from .. import studies
    if kind not in STUDY_KINDS:
        raise InputError("unknown study %r (known: %s)" % (kind, ", ".join(STUDY_KINDS)))
    if kind in BREP_ONLY and not isinstance(source, str):
        raise InputError("the %s study needs a BRep (Part) source, not a mesh" % kind)
    quad = {k: options[k] for k in QUADRATURE_KEYS if k in options}
    lref, h_f, k_f = options.get("lref"), options["h_f"], options["k_f"]
    if kind == "sameface":
        return studies.sameface_study(source, faces=faces, progress=progress)
    if kind == "refinement":
        return studies.refinement_study(source=source, lref=lref, h_f=h_f, k_f=k_f, faces=faces, progress=progress)
    if kind == "representation":
        return studies.representation_study(source, lref=lref, h_f=h_f, k_f=k_f, faces=faces, brep_options=quad,
                                            progress=progress)
    from ..studies.thresholds import DEFAULT_TOLERANCES
    tolerances = sorted(set(DEFAULT_TOLERANCES) | ({h_f} if h_f == k_f else set()))  # a row repeats the analysis
    return studies.threshold_study(source, tolerances=tolerances, lref=lref, faces=faces, progress=progress,
                                   **quad)


def default_report_path(document_file, label, kind, home=None):
    """The report's default file: beside the document's file (the home folder for an
    unsaved document), named after the object's label and the study."""
    folder = os.path.dirname(document_file) if document_file else (home or os.path.expanduser("~"))
    stem = re.sub(r"[^\w.-]+", "_", label).strip("_") or "hull"
    return os.path.join(folder, "%s_%s_study.html" % (stem, kind))
