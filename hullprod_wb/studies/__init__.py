"""Verification studies and reports (paper section 5 and the tables of section 6).

GUI-free Python API; each study returns a plain JSON-safe dict:

    sameface_study(source, faces=None, levels=(12, 24, 48), patterns=('consistent', 'alternating'),
                   inset=0.05, curvature=None, progress=None, abs_K_share=None, align_creases=True)
    refinement_study(source=None, meshes=None, lref=None, h_f=1e-4, k_f=1e-4,
                     linear=(0.0035, 0.00175, 0.000875), angular=(0.3, 0.25, 0.2), faces=None,
                     names=None, progress=None)
    representation_study(source, mesh=None, lref=None, mesh_lref=None, h_f=1e-4, k_f=1e-4,
                         faces=None, linear=0.000875, angular=0.2, brep_options=None,
                         progress=None, brep_assessment=None)
    threshold_study(source, tolerances=(1e-5, 1e-4, 1e-3), lref=None, backend=None, faces=None,
                    progress=None, **quadrature_options)
    write_report(assessment, path, studies=None) -> path of the HTML file

progress is a callable progress(fraction, message).
"""
import importlib

#: Public name -> module; modules are imported on first use (the command line registers the
#: study commands without importing the meshing and plotting libraries they need).
_EXPORTS = {"refinement_study": "refinement", "report_html": "report", "write_report": "report",
            "representation_study": "representation", "sameface_study": "sameface",
            "threshold_study": "thresholds"}


def __getattr__(name):
    if name in _EXPORTS:
        return getattr(importlib.import_module("." + _EXPORTS[name], __name__), name)
    raise AttributeError("module %r has no attribute %r" % (__name__, name))

__all__ = ["sameface_study", "refinement_study", "representation_study", "threshold_study",
           "write_report", "report_html"]
