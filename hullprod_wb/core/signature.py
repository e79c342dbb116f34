"""The global signature vector I_sig = [I_D, I_D+, I_D-, a_C] (paper eq:vector)."""
import numpy as np

from .constants import CLASS_METRICS


def signature_values(integrals, lref):
    """Candidate signature values from surface integrals.

    I_D = L_ref^2 int|K| dA / A_K (eq:dev), I_D+- = L_ref^2 int max(+-K,0) dA / A_K
    (eq:devsigned), a_C = class areas / A_C (eq:classes). Returns a dict keyed by
    :data:`METRICS`; an entry whose denominator is zero is NaN.
    """
    A_K = integrals.valid_area
    A_C = integrals.classified_area
    L2 = float(lref) ** 2
    out = {}
    with np.errstate(divide="ignore", invalid="ignore"):
        out["I_D"] = L2 * integrals.int_abs_K / A_K if A_K > 0 else float("nan")
        out["I_D_plus"] = L2 * integrals.int_K_plus / A_K if A_K > 0 else float("nan")
        out["I_D_minus"] = L2 * integrals.int_K_minus / A_K if A_K > 0 else float("nan")
        for name, area in zip(CLASS_METRICS, integrals.class_areas):
            out[name] = float(area) / A_C if A_C > 0 else float("nan")
    return {k: float(v) for k, v in out.items()}
