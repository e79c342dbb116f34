"""The global signature vector I_sig = [I_D, I_D+, I_D-, a_C] (paper eq:vector)."""
import numpy as np

from .constants import CLASS_METRICS

#: Multiple of the machine epsilon that bounds the rounding of K L_ref^2 relative to the
#: curvature scale of the surface (rounding_bound): K = (eg - f^2) / (EG - F^2) is formed
#: from second derivatives that each carry a few eps, and the cubature sums many such values.
ROUNDING_FACTOR = 1024.0

#: The metrics that are K integrals over A_K, zero when they are at or below rounding.
K_METRICS = ("I_D", "I_D_plus", "I_D_minus")


def rounding_bound(i_d):
    """The value at or below which I_D, I_D+ and I_D- cannot be told from 0 in double
    precision: ROUNDING_FACTOR eps (1 + I_D), with I_D (the mean |K| L_ref^2, eq:dev) and
    1 (a curvature of 1/L_ref) standing for the curvature scale the rounding is relative to."""
    scale = abs(i_d) if np.isfinite(i_d) else 0.0
    return ROUNDING_FACTOR * np.finfo(float).eps * (1.0 + scale)


def signature_values(integrals, lref):
    """Candidate signature values from surface integrals.

    I_D = L_ref^2 int|K| dA / A_K (eq:dev), I_D+- = L_ref^2 int max(+-K,0) dA / A_K
    (eq:devsigned), a_C = class areas / A_C (eq:classes). Returns a dict keyed by
    :data:`METRICS`; an entry whose denominator is zero is NaN; an I_D, I_D+ or I_D- at or
    below rounding_bound(I_D) is 0.
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
    bound = rounding_bound(out["I_D"])
    for m in K_METRICS:
        if abs(out[m]) <= bound:
            out[m] = 0.0
    return {k: float(v) for k, v in out.items()}
