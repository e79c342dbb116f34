"""Many hulls at once: batch assessment locally in parallel or on a Dask cluster, and the
signature as a function of design parameters for optimisation loops."""
import importlib

#: Public name -> module, imported on first use (see hullprod_wb.studies).
_EXPORTS = {"BatchResult": "api", "assess_many": "api", "run_batch": "api",
            "SignatureObjective": "objective", "DocumentHull": "parametric"}
__all__ = list(_EXPORTS)


def __getattr__(name):
    if name in _EXPORTS:
        return getattr(importlib.import_module("." + _EXPORTS[name], __name__), name)
    raise AttributeError("module %r has no attribute %r" % (__name__, name))
