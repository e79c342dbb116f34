"""Cross-checks of an assessed BRep face, independent of the adaptive cubature: derivatives
and H, K against OpenCascade at interior points of the face's parameter range, and the
represented area by a fixed tensor Gauss-Legendre rule on its boundary-fitted patches."""
import time

import numpy as np

from ..cubature import patch_area
from ..reading.occ_records import CROSS_CHECK_POINTS, cross_check_params, occ_reference


def cross_check_occ(ff, reference=None, n=CROSS_CHECK_POINTS):
    """Max relative differences of S_u, S_v, H, K against OpenCascade at interior points of
    the face's parameter range (occ_records.cross_check_params); reference: OpenCascade's
    values there (occ_records.occ_reference), computed from ff.face when not given."""
    if reference is None:
        reference = occ_reference(ff.face, n)
    u, v = (np.array(x) for x in cross_check_params(ff.evaluator.parameter_range, n))
    ours = ff(u, v)
    der = ff.evaluator.derivatives(u, v)
    worst = {"Su": 0.0, "Sv": 0.0, "H": 0.0, "K": 0.0}
    checked = 0
    for i in range(n):
        if reference[i] is None:  # undefined curvature at a degenerate point: nothing to compare
            continue
        du, dv, Kocc, Hocc = reference[i]
        Hocc = ff.sign * Hocc
        checked += 1
        for name, a, b in (("Su", der[1][i], du), ("Sv", der[2][i], dv)):
            b = np.array(b)
            worst[name] = max(worst[name], float(np.linalg.norm(a - b) / max(np.linalg.norm(b), 1e-300)))
        for name, a, b in (("H", ours["H"][i], Hocc), ("K", ours["K"][i], Kocc)):
            scale = max(abs(b), abs(ours["k1"][i] * ours["k2"][i]) if name == "K" else abs(b), 1e-300)
            scale = max(scale, ours["k1"][i] ** 2 if name == "K" else abs(ours["k1"][i]), 1e-300)
            worst[name] = max(worst[name], float(abs(a - b) / scale))
    worst["points"] = checked
    return worst


def area_rule(ff, domain, u_breaks, v_breaks):
    """Represented area by the fixed tensor Gauss-Legendre rule of order 8 on every
    boundary-fitted patch (cubature.patch_area), an estimate independent of the adaptive
    cubature, and the embedded-rule bound on its own error: (area, bound). Only J is
    evaluated (first derivatives: FaceField.area_element)."""
    return patch_area(domain, ff.area_element, 8, u_breaks, v_breaks, ff.area_element_grid)


def area_cross_check(rule, area):
    """The record comparing the adaptive cubature's area with area_rule's (area, bound)."""
    ref, bound = rule
    return {"method": "tensor Gauss-Legendre order 8 on the boundary-fitted patches",
            "area": ref, "check_error_bound": bound,
            "relative_difference": abs(area - ref) / ref if ref else None}


def face_cross_checks(f, rule=None, seconds=0.0, reference=None):
    """Cross-checks of one assessed face (needs its field and domain): derivatives and H, K
    against OpenCascade at interior points (reference: OpenCascade's values there, when
    already known), and the independent fixed-rule area (rule: its area_rule when already
    computed, in seconds)."""
    t = time.perf_counter()
    rec = {"face": f.number, "occ_pointwise_max_relative": cross_check_occ(f.ff, reference)}
    if rule is None:
        rule = area_rule(f.ff, f.domain, f.u_breaks, f.v_breaks)
    rec["area"] = area_cross_check(rule, f.quad.values["A"])
    rec["seconds"] = seconds + time.perf_counter() - t
    return rec
