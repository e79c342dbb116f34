"""Validity rules of the BRep metrics (paper section 4.3) over the assessed faces: one error
budget for the shape (a metric's quantities converged when their summed error estimates fit
rtol of the totals), the audits' verdicts (SINGULAR, CAUTION, VALID*), trim-domain
fallbacks, refinements that disagree, the I_D stability rule (section 5.2), the per-face
records and the threshold band of the class fractions."""
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ...core.constants import CLASS_METRICS, CLASS_NAMES, METRICS
from ...core.signature import K_METRICS, rounding_bound, signature_values
from ...core.validity import MetricValidity, Qualification, Status
from ..cubature.settings import CLASS_AREAS, QUANTITIES, ZERO_SCALE

#: The class-area quantities (flat, single, elliptic, saddle).
CLASS_QUANTITIES = QUANTITIES[CLASS_AREAS]

#: Stability rule for I_D over the global refinement sequence: last and prior relative change.
ID_STABILITY = (0.02, 0.03)


#: A face whose share of int|K| exceeds this many times its share of area (and 1 %) is named.
CONCENTRATION_RATIO = 20.0


#: Numerator and denominator quantities of each metric.
METRIC_QUANTITIES = {"I_D": ("int_abs_K", "A_valid"), "I_D_plus": ("int_K_plus", "A_valid"),
                     "I_D_minus": ("int_K_minus", "A_valid"),
                     "a_flat": ("A_flat", "A_classified"), "a_single": ("A_single", "A_classified"),
                     "a_elliptic": ("A_elliptic", "A_classified"), "a_saddle": ("A_saddle", "A_classified")}


#: Relative width of the threshold bands recorded with the class fractions (threshold_band).
THRESHOLD_BAND = 0.1


#: ... and a disagreement qualifies a metric when it exceeds this share of its total's tolerance.
DISAGREEMENT_SHARE = 0.1


def global_tolerance(faces, quantity, rtol):
    """Tolerance of a quantity's total over the faces: rtol max(|total|, 1e-2 A) for areas,
    rtol |total| for the K integrals."""
    total = sum(f.quad.values[quantity] for f in faces)
    scale = max(abs(total), 1e-2 * sum(f.quad.values["A"] for f in faces)
                if quantity.startswith("A") else abs(total))
    return rtol * scale


def global_converged(faces, quantity, rtol):
    """Converged on every face, or the summed error estimate within the total's tolerance
    (global_tolerance): one error budget for the whole shape."""
    if all(f.quad.converged[quantity] for f in faces):
        return True
    return sum(f.quad.errors[quantity] for f in faces) <= global_tolerance(faces, quantity, rtol)


def _quantity_total(faces, q):
    if q == "A_classified":
        return sum(f.quad.values[c] for f in faces for c in CLASS_QUANTITIES)
    return sum(f.quad.values[q] for f in faces)


def face_records(faces, integrals, lref):
    """Per-face table: area, shares, face-level signature, status, surface type."""
    A_tot = integrals.valid_area
    K_tot = integrals.int_abs_K
    rows = []
    for f in faces:
        r = f.quad
        ig = r.integrals()
        vals = signature_values(ig, lref)
        verdicts = [a["verdict"] for a in f.audits]
        if not r.all_converged:
            status = Status.UNCONVERGED
        elif "divergent" in verdicts:
            status = Status.SINGULAR
        elif "inconclusive" in verdicts or "not_audited" in verdicts:
            status = Status.CAUTION
        elif "convergent" in verdicts:
            status = Status.VALID_STAR
        else:
            status = Status.VALID
        rows.append({
            "face": f.number, "surface_type": f.surface_type, "evaluation": f.kind,
            "rounding_bound": rounding_bound(vals["I_D"]),
            "area": r.values["A"], "valid_area": r.values["A_valid"],
            "area_share": r.values["A_valid"] / A_tot if A_tot > 0 else None,
            "K_share": r.values["int_abs_K"] / K_tot if K_tot > 0 else None,
            "I_D": vals["I_D"], "I_D_plus": vals["I_D_plus"], "I_D_minus": vals["I_D_minus"],
            "a_C": {n: vals[m] for n, m in zip(CLASS_NAMES, CLASS_METRICS)},
            "status": status.value, "converged": bool(r.all_converged),
            "refinements_disagree": dict(getattr(f, "disagreement", None) or {}),
            "points": int(f.quad.n_points),
            "depth_reached": int(r.depth_reached), "trimmed": not f.domain.is_rectangle,
            "domain": ("polygon from the 3-D edges (%s)" % f.domain.fallback) if f.domain.fallback
            else "exact p-curves" + (" (repaired: %s)" % "; ".join(f.domain.repairs)
                                     if getattr(f.domain, "repairs", None) else ""),
            "repairs": list(getattr(f.domain, "repairs", [])),
            "degenerate": f.degenerate.to_dict(),
        })
    return rows


def concentrated_faces(rows):
    """Faces whose share of int|K| is far beyond their share of area (slivers, collapsed patches)."""
    out = []
    for r in rows:
        a, k = r["area_share"], r["K_share"]
        if a is not None and k is not None and k > 0.01 and (a <= 0 or k / a > CONCENTRATION_RATIO):
            out.append({"face": r["face"], "area": r["area"], "area_share": a, "K_share": k})
    return out


@dataclass
class MetricCase:
    """What the validity rules read of one metric: its name, whether it is a K integral's
    (is_K: I_D, I_D+, I_D- over A_valid), whether its quantities converged under the shape's
    error budget (global_converged), the shape's valid area, the audits and their verdicts,
    the global refinement sequence (history), the faces whose two integrations disagree on
    it (disagreeing_refinements), the faces whose trim domain is a polygon (fallback), the
    degenerate points and sides counted, the quadrature options, the evidence so far, and
    the floor under which I_D counts as zero in the stability rule (id_zero: ZERO_SCALE k_f)."""

    metric: str
    is_K: bool
    converged: bool
    valid_area: float
    audits: list
    verdicts: list
    history: list
    disagreeing: list
    fallback: list
    degenerate_count: int
    opts: object  # budget.QuadratureOptions
    evidence: dict
    id_zero: float


def _no_evidence(case):
    return {}


def _audit_evidence(case):
    return {"audit": case.audits}


@dataclass(frozen=True)
class ValidityRule:
    """One row of VALIDITY_RULES: a metric whose case satisfies applies(case) gets status,
    code and reason(case), and the entries of evidence(case) added to its evidence; its
    value goes with it when keeps_value (MetricValidity keeps it as the finite candidate
    where the status does not establish it)."""

    status: Status
    code: str
    applies: Callable
    reason: Callable
    evidence: Callable = _no_evidence
    keeps_value: bool = True


def _unresolved_reason(case):
    opts, evidence, rtol = case.opts, case.evidence, case.opts.rtol
    if opts.paper:
        return ("adaptive quadrature did not reach the tolerance %g at depth %d, nor at %d"
                % (rtol, opts.max_depth, opts.max_depth + 1))
    return ("the summed error estimate %.3g exceeds the tolerance %.3g (rtol %g of the total) with the "
            "point budget spent on face(s) %s" % (evidence["error_estimate"], evidence["tolerance"], rtol,
                                                  ",".join(map(str, evidence["budget_spent_faces"])) or "none"))


def _improper_reason(case):
    pw = [a["decay_power"] for a in case.audits if a["verdict"] == "convergent"]
    return ("convergent improper integral: |K| is unbounded at %d degenerate point(s); the "
            "excluded |K| integral decays like r^%.2f" % (len(pw), min(pw)))


def _degenerate_reason(case):
    if all(v == "regular" for v in case.verdicts):
        return ("converged; %d degenerate parameter point(s)/side(s) with bounded curvature "
                "(parameterisation degeneracy)" % case.degenerate_count)
    return "converged; singular points carry zero area"


#: The validity rules of a metric (paper section 4.3), in order: the first whose condition
#: holds gives the metric's record. No regular area to evaluate; the quantities not converged
#: under the shape's error budget; for the K integrals, an audit whose excluded |K| integral
#: does not shrink; for I_D, an unstable global refinement sequence (section 5.2); for the K
#: integrals, degenerate points not shown regular or convergent, then a convergent improper
#: integral; refinements whose integrations disagree; trim domains that are polygons;
#: converged with degenerate points or sides; converged.
VALIDITY_RULES = (
    ValidityRule(Status.NOT_EVALUATED, "no_valid_area", lambda c: c.valid_area <= 0,
                 lambda c: "no regular surface area to evaluate", keeps_value=False),
    ValidityRule(Status.UNCONVERGED, "quadrature_unresolved", lambda c: not c.converged, _unresolved_reason),
    ValidityRule(Status.SINGULAR, "non_integrable_singularity", lambda c: c.is_K and "divergent" in c.verdicts,
                 lambda c: "the |K| integral does not shrink with the neighbourhood of a singular point",
                 _audit_evidence),
    ValidityRule(Status.UNCONVERGED, "refinement_unstable",
                 lambda c: c.metric == "I_D" and bool(c.history) and not _stable(c.history, c.id_zero),
                 lambda c: "I_D changed by more than 2 %/3 % over the last global refinements",
                 lambda c: {"refinement_sequence": c.history}),
    ValidityRule(Status.CAUTION, "singular_set_unresolved",
                 lambda c: c.is_K and ("inconclusive" in c.verdicts or "not_audited" in c.verdicts),
                 lambda c: "degenerate points whose neighbourhood could not be shown regular or convergent",
                 _audit_evidence),
    ValidityRule(Status.VALID_STAR, "convergent_improper", lambda c: c.is_K and "convergent" in c.verdicts,
                 _improper_reason, _audit_evidence),
    ValidityRule(Status.CAUTION, "error_estimate_unreliable", lambda c: bool(c.disagreeing),
                 lambda c: "face(s) %s: a finer integration differs from the earlier one by more than their "
                           "error estimates, which are therefore not reliable there"
                           % ",".join(str(b["face"]) for b in c.disagreeing),
                 lambda c: {"disagreeing_refinements": c.disagreeing}),
    ValidityRule(Status.CAUTION, "approximate_trim_domain", lambda c: bool(c.fallback),
                 lambda c: "face(s) %s: trim curves do not close; their domain is a polygon from the "
                           "3-D edges" % ",".join(str(n) for n in c.fallback),
                 lambda c: {"approximate_domains": c.fallback}),
    ValidityRule(Status.VALID, "converged_degenerate_parameterisation", lambda c: bool(c.degenerate_count),
                 _degenerate_reason, _audit_evidence),
    ValidityRule(Status.VALID, "converged", lambda c: True, lambda c: ""),
)


def metric_validity(faces, integrals, values, opts, history, k_f):
    """Validity record of each signature metric (paper section 4.3): the first of
    VALIDITY_RULES that holds for it, with the evidence of the shape's error budget, then
    I_D's refinement sequence and the polygon trim domains named on every record."""
    rtol = opts.rtol
    audits = [a for f in faces for a in f.audits]
    verdicts = [a["verdict"] for a in audits]
    deg_count = sum(len(f.degenerate.points) + len(f.degenerate.interior) + len(f.degenerate.sides)
                    for f in faces)
    fallback = [f.number for f in faces if f.domain.fallback]
    # exact repairs of trim loops (gaps within a vertex's tolerance): no CAUTION, but evidence
    repaired = [f.number for f in faces if f.domain.repairs]
    rep, valid = integrals.represented_area, integrals.valid_area
    out = {}
    for m in METRICS:
        num, den = METRIC_QUANTITIES[m]
        conv = global_converged(faces, num, rtol) and (
            den == "A_classified" or global_converged(faces, den, rtol))
        if den == "A_classified":
            conv = conv and all(global_converged(faces, c, rtol) for c in CLASS_QUANTITIES)
        evidence = {"error_estimate": sum(f.quad.errors.get(num, 0.0) for f in faces),
                    "numerator": _quantity_total(faces, num), "denominator": _quantity_total(faces, den),
                    "points": int(sum(f.quad.n_points for f in faces))}
        evidence["tolerance"] = global_tolerance(faces, num, rtol)
        if opts.paper:
            evidence.update({"depth_limit": opts.max_depth, "recheck_depth": opts.max_depth + 1,
                             "rechecked_faces": [f.number for f in faces if f.quad.rechecked]})
        else:
            evidence.update({"depth_limit": opts.depth_limit, "point_budget": opts.point_budget,
                             "budget_spent_faces": [f.number for f in faces if f.quad.budget_spent]})
        if repaired:
            evidence["repaired_domains"] = repaired
        if m in K_METRICS:
            evidence.update(rounding_evidence(values, m, evidence["numerator"]))
        case = MetricCase(m, den == "A_valid", conv, valid, audits, verdicts, history,
                          disagreeing_refinements(faces, num, den, rtol), fallback, deg_count, opts, evidence,
                          ZERO_SCALE * k_f)
        rule = next(r for r in VALIDITY_RULES if r.applies(case))
        evidence.update(rule.evidence(case))
        rec = MetricValidity(rule.status, values[m] if rule.keeps_value else None, rule.reason(case), rule.code,
                             rep, valid, evidence)
        if m == "I_D" and history:
            rec.evidence["refinement_sequence"] = history
        if fallback and rec.code != "approximate_trim_domain":
            rec.qualify(Qualification(
                "approximate_trim_domain", "face(s) %s: trim curves do not close, domain from the 3-D edges"
                % ",".join(map(str, fallback)), {"approximate_domains": fallback}, caution=False))
        out[m] = rec
    return out


def rounding_evidence(values, m, numerator):
    """rounding_bound: the value at or below which the K metric m counts as 0 (core/signature
    rounding_bound of I_D), and at_rounding: whether m was set to 0 from a non-zero integral
    (the evidence's numerator keeps that integral)."""
    bound = rounding_bound(values["I_D"])
    return {"rounding_bound": bound, "at_rounding": bool(values[m] == 0.0 and numerator != 0.0)}


def disagreeing_refinements(faces, num, den, rtol):
    """Faces integrated again whose two integrations disagree on the quantities of a metric
    (numerator num, denominator den) beyond their error estimates, by more than
    DISAGREEMENT_SHARE of the total's tolerance (global_tolerance), with both values."""
    qs = {num, den} if den != "A_classified" else {num, *CLASS_QUANTITIES}
    tol = {q: global_tolerance(faces, q, rtol) for q in qs}
    out = []
    for f in faces:
        d = getattr(f, "disagreement", None) or {}
        hit = {q: d[q] for q in sorted(qs) if q in d and abs(d[q][1] - d[q][0]) > DISAGREEMENT_SHARE * tol[q]}
        if hit:
            out.append({"face": f.number, "values": hit})
    return out


def _stable(history, zero=0.0):
    """I_D stability rule (section 5.2): last and prior relative changes <= 2 % and 3 %,
    relative to |I_D| or zero, whichever is larger: an I_D under zero (ZERO_SCALE k_f, as the
    cubature's own floor tau_K A scaled by L_ref^2 / A) is zero to the classification, and its
    changes are rounding."""
    seq = [h["I_D"] for h in history if h.get("I_D") is not None]
    if len(seq) < 3:
        return True

    def change(new, old):
        scale = max(abs(new), zero)
        return abs(new - old) / scale if scale > 0 else 0.0
    return change(seq[-1], seq[-2]) <= ID_STABILITY[0] and change(seq[-2], seq[-3]) <= ID_STABILITY[1]


def refinement_history(faces, lref):
    """Global I_D, I_D+, I_D- after each quadtree level (summed over faces), when recorded."""
    per_face = [getattr(f.quad, "history", None) for f in faces]
    if not per_face or any(h is None for h in per_face):
        return []
    depth = max(len(h) for h in per_face)
    out = []
    for d in range(depth):
        tot = {}
        for h in per_face:
            vals = h[min(d, len(h) - 1)]
            for k, v in vals.items():
                tot[k] = tot.get(k, 0.0) + v
        A = tot.get("A_valid", 0.0)
        out.append({"depth": d, "I_D": lref ** 2 * tot["int_abs_K"] / A if A else None,
                    "I_D_plus": lref ** 2 * tot["int_K_plus"] / A if A else None,
                    "I_D_minus": lref ** 2 * tot["int_K_minus"] / A if A else None})
    return out


def threshold_band(fields, th, width=THRESHOLD_BAND):
    """Share of the valid area where K lies within width tau_K of +-tau_K, and where H lies
    within width tau_H of +-tau_H, at the display tessellation's nodes (each node weighted by
    a third of its triangles' areas): the area whose class would change with a threshold
    moved by that much, i.e. how sensitive the class fractions are to the thresholds
    (eq:class_thresholds)."""
    P, T = np.asarray(fields.points, float), np.asarray(fields.triangles, int)
    if T.size == 0:
        return None
    a = 0.5 * np.linalg.norm(np.cross(P[T[:, 1]] - P[T[:, 0]], P[T[:, 2]] - P[T[:, 0]]), axis=1)
    w = np.bincount(T.ravel(), weights=np.repeat(a / 3.0, 3), minlength=len(P))
    w = np.where(np.asarray(fields.valid, bool), w, 0.0)
    total = w.sum()
    if total <= 0:
        return None
    K, H = np.abs(np.asarray(fields.K, float)), np.abs(np.asarray(fields.H, float))
    with np.errstate(invalid="ignore"):
        k_band = np.abs(K - th.tau_K) <= width * th.tau_K
        h_band = np.abs(H - th.tau_H) <= width * th.tau_H
    return {"relative_width": width, "K_band_area_fraction": float(w[k_band].sum() / total),
            "H_band_area_fraction": float(w[h_band].sum() / total),
            "source": "display tessellation nodes"}
