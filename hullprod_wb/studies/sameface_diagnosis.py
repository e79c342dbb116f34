"""What limits a same-face error, measured on the study's own grid (paper section 5.2).

Per level record (:func:`level_measures`), from the grid vertices S(u, v), the BRep
principal curvatures and the pointwise errors on the retained vertices (lumped mass
w_i = sum_j M_ij of the consistent P1 mass matrix as vertex area):

* ``panel_aspect``: physical aspect ratio of each panel, max(l_u, l_v) / min(l_u, l_v)
  with l_u, l_v the mean lengths of its two pairs of opposite edges; median, 95th
  percentile and maximum over the panels;
* ``h_kappa``: h kappa_max at each retained vertex, h the longest grid edge at the vertex
  and kappa_max = max(|k1|, |k2|) of the BRep; its maximum, its 95th percentile (area
  weighted) and the area fraction above UNDER_RESOLVED (a panel turning by more than half
  a radian);
* ``variation``: per quantity X in {H, K} of the BRep, the largest change of X to a grid
  neighbour over the RMS of X (max_step_over_rms) and the area fraction where it exceeds
  STEEP_VARIATION (X changes by more than its RMS across one panel: the curvature field is
  under-resolved even where the surface's radius is many panels);
* ``worst_1pct``: per quantity X in {H, K}, the share of the squared error sum w_i d_i^2
  carried by the worst WORST_AREA (1 %) of the retained area (largest d_i^2 first);
* ``error_share``: per quantity, the share of the squared error on the under-resolved
  vertices, on the steep-variation vertices, on the vertices whose two-ring reaches a knot line below C2 or a close knot
  pair, and on the vertices of high-aspect panels (aspect >= HIGH_ASPECT).

Per face (:func:`face_diagnosis`), from the finest level: the knot structure inside the
region (C0 creases, C1 lines, close knot pairs: distinct knot lines closer than
CLOSE_KNOTS of the grid spacing, which act as one line of higher multiplicity that the
continuity test does not see; knot spans per panel) and the causes named from the
measures above: ``resolution``, ``curvature variation``, ``panel aspect``, ``knot lines``
(each when the vertices it covers carry at least CAUSE_SHARE of a squared error), ``knot
spans finer than panels``, ``not refining`` (finest error not below the coarsest),
``localized`` (the worst 1 % carries at least LOCALIZED_SHARE), ``reference quasi-zero`` and
``every vertex masked``.
"""
import numpy as np

#: h kappa_max above which a panel turns by more than half a radian: under-resolved.
UNDER_RESOLVED = 0.5
#: A curvature X whose change to a grid neighbour exceeds this multiple of its RMS varies
#: faster than the grid resolves (its value is not one number over a panel).
STEEP_VARIATION = 1.0
#: Panel aspect ratio from which the panels count as stretched.
HIGH_ASPECT = 10.0
#: Fraction of the retained area whose share of the squared error is reported.
WORST_AREA = 0.01
#: Distinct knot lines closer than this fraction of the grid spacing are a close pair.
CLOSE_KNOTS = 1e-3
#: A cause is named when the vertices it covers carry at least this share of the squared
#: error (a third: the largest of three equal contributions).
CAUSE_SHARE = 1.0 / 3.0
#: Share of the squared error on the worst WORST_AREA from which the error is localized.
LOCALIZED_SHARE = 0.5


def diagnosis_settings():
    """The constants of the diagnosis, recorded in the study document's settings."""
    return {"under_resolved_h_kappa": UNDER_RESOLVED, "steep_variation_over_rms": STEEP_VARIATION,
            "high_panel_aspect": HIGH_ASPECT, "worst_area_fraction": WORST_AREA,
            "close_knots_fraction_of_spacing": CLOSE_KNOTS, "cause_share": CAUSE_SHARE,
            "localized_share": LOCALIZED_SHARE}


def _norms(x):
    return np.sqrt(np.einsum("...k,...k->...", x, x))


def panel_aspects(V, n):
    """(n, n) physical aspect ratios of the panels of an (n+1) x (n+1) grid V ((n+1)^2, 3)."""
    P = np.asarray(V, dtype=float).reshape(n + 1, n + 1, 3)
    eu = _norms(P[1:, :] - P[:-1, :])               # (n, n+1): edges along u
    ev = _norms(P[:, 1:] - P[:, :-1])               # (n+1, n): edges along v
    lu = 0.5 * (eu[:, :-1] + eu[:, 1:])
    lv = 0.5 * (ev[:-1, :] + ev[1:, :])
    lo, hi = np.minimum(lu, lv), np.maximum(lu, lv)
    return np.where(lo > 0, hi / np.where(lo > 0, lo, 1.0), np.inf)


def vertex_spacing(V, n):
    """((n+1)^2,) longest grid edge at each vertex of the grid."""
    P = np.asarray(V, dtype=float).reshape(n + 1, n + 1, 3)
    h = np.zeros((n + 1, n + 1))
    eu = _norms(P[1:, :] - P[:-1, :])
    ev = _norms(P[:, 1:] - P[:, :-1])
    h[1:, :] = np.maximum(h[1:, :], eu)
    h[:-1, :] = np.maximum(h[:-1, :], eu)
    h[:, 1:] = np.maximum(h[:, 1:], ev)
    h[:, :-1] = np.maximum(h[:, :-1], ev)
    return h.ravel()


def vertex_aspect(aspect, n):
    """((n+1)^2,) largest aspect ratio of the panels around each vertex."""
    a = np.zeros((n + 1, n + 1))
    for di in (0, 1):
        for dj in (0, 1):
            a[di:di + n, dj:dj + n] = np.maximum(a[di:di + n, dj:dj + n], aspect)
    return a.ravel()


def grid_variation(x, n):
    """((n+1)^2,) largest |x_i - x_j| over the grid neighbours j of each vertex (NaN-safe)."""
    X = np.asarray(x, dtype=float).reshape(n + 1, n + 1)
    out = np.zeros((n + 1, n + 1))
    du = np.abs(np.nan_to_num(X[1:, :] - X[:-1, :]))
    dv = np.abs(np.nan_to_num(X[:, 1:] - X[:, :-1]))
    out[1:, :] = np.maximum(out[1:, :], du)
    out[:-1, :] = np.maximum(out[:-1, :], du)
    out[:, 1:] = np.maximum(out[:, 1:], dv)
    out[:, :-1] = np.maximum(out[:, :-1], dv)
    return out.ravel()


def worst_area_share(err2, w, fraction=WORST_AREA):
    """Share of sum(w err2) carried by the largest err2 values covering `fraction` of sum(w)
    (the vertex that crosses the fraction included); None when the error is zero."""
    total = float(np.sum(w * err2))
    if not total > 0.0:
        return None
    order = np.argsort(-err2, kind="stable")
    area = np.cumsum(w[order])
    k = int(np.searchsorted(area, fraction * area[-1])) + 1
    return float(np.sum((w * err2)[order[:k]]) / total)


def _share(err2, w, where):
    total = float(np.sum(w * err2))
    return float(np.sum((w * err2)[where]) / total) if total > 0.0 else None


def level_measures(V, n, k1, k2, d_H, d_K, w, mask, knot_band, H_ref=None, K_ref=None):
    """The measures of one level record (module docstring).

    V ((n+1)^2, 3) grid vertices, k1, k2 BRep principal curvatures, d_H, d_K pointwise
    errors, w lumped vertex areas, mask retained vertices, knot_band vertices whose
    two-ring reaches a knot line below C2 or a close knot pair, H_ref, K_ref the BRep H, K;
    all ((n+1)^2,).
    """
    aspect = panel_aspects(V, n)
    fin = aspect[np.isfinite(aspect)]
    if fin.size:
        pa = {"median": float(np.median(fin)), "p95": float(np.percentile(fin, 95)), "max": float(fin.max())}
    else:
        why = "every panel has a zero-length side (degenerate grid)"
        pa = {"median": None, "p95": None, "max": None, "reasons": dict.fromkeys(("median", "p95", "max"), why)}
    out = {"panel_aspect": pa}
    m = np.asarray(mask, dtype=bool)
    if not m.any():
        out.update(h_kappa=None, variation=None, worst_1pct=None, error_share=None)
        return out
    hk = vertex_spacing(V, n) * np.maximum(np.abs(k1), np.abs(k2))
    hk_m, w_m = hk[m], w[m]
    order = np.argsort(hk_m)
    cum = np.cumsum(w_m[order])
    p95 = float(hk_m[order][min(int(np.searchsorted(cum, 0.95 * cum[-1])), len(order) - 1)])
    under = hk_m > UNDER_RESOLVED
    out["h_kappa"] = {"max": float(hk_m.max()), "p95": p95,
                      "area_fraction_under_resolved": float(w_m[under].sum() / w_m.sum())}
    stretched = vertex_aspect(aspect, n)[m] >= HIGH_ASPECT
    band = np.asarray(knot_band, dtype=bool)[m]
    out["worst_1pct"], out["error_share"], out["variation"] = {}, {}, {}
    for q, d, x in (("H", d_H, H_ref), ("K", d_K, K_ref)):
        e2 = np.where(np.isfinite(d[m]), d[m], 0.0) ** 2
        rms = float(np.sqrt(np.sum(w_m * np.nan_to_num(x[m]) ** 2) / w_m.sum()))
        jump = grid_variation(x, n)[m] / rms if rms > 0 else np.zeros(m.sum())
        steep = jump > STEEP_VARIATION
        out["variation"][q] = {"max_step_over_rms": float(jump.max()),
                               "area_fraction_steep": float(w_m[steep].sum() / w_m.sum())}
        out["worst_1pct"][q] = worst_area_share(e2, w_m)
        out["error_share"][q] = {"under_resolved": _share(e2, w_m, under),
                                 "steep_variation": _share(e2, w_m, steep),
                                 "knot_lines": _share(e2, w_m, band),
                                 "stretched_panels": _share(e2, w_m, stretched)}
    return out


def knot_structure(evaluator, rect, n):
    """Knot lines inside rect: C0 creases, C1 lines, close pairs (module docstring) and knot
    spans per panel at n panels, per direction u, v."""
    all_u, all_v = evaluator.continuity_breaks(None, urange=rect[:2], vrange=rect[2:])
    c0 = evaluator.continuity_breaks(min_continuity=1, urange=rect[:2], vrange=rect[2:])
    c1 = evaluator.continuity_breaks(min_continuity=2, urange=rect[:2], vrange=rect[2:])
    out = {}
    for k, (lines, lo, hi) in enumerate(((all_u, rect[0], rect[1]), (all_v, rect[2], rect[3]))):
        name = "uv"[k]
        gaps = np.diff(np.r_[lo, np.asarray(lines, dtype=float), hi])
        close = np.asarray(lines)[np.flatnonzero(gaps[1:-1] < CLOSE_KNOTS * (hi - lo) / n)] \
            if len(lines) > 1 else np.empty(0)
        out[name] = {"knot_lines": int(len(lines)), "creases": int(len(c0[k])),
                     "c1_lines": int(len(np.setdiff1d(c1[k], c0[k]))),
                     "close_pairs": close, "spans_per_panel": float((len(lines) + 1) / n)}
    return out


def close_pair_lines(knots):
    """(u_lines, v_lines) of the close knot pairs of a :func:`knot_structure` record."""
    return np.asarray(knots["u"]["close_pairs"], dtype=float), np.asarray(knots["v"]["close_pairs"], dtype=float)


def _pct(x):
    return ("%.0f %%" if x >= 0.01 else "%.2g %%") % (100.0 * x)


def _worst(records, path):
    """Largest value at the nested key path over the records (None when absent everywhere)."""
    vals = []
    for r in records:
        x = r
        for p in path:
            x = x.get(p) if isinstance(x, dict) else None
        if x is not None:
            vals.append(x)
    return max(vals) if vals else None


def _shares(finest, part):
    """'H 78 %, K 70 %' for the quantities whose error share on `part` reaches CAUSE_SHARE."""
    got = [(q, _worst(finest, ("error_share", q, part))) for q in ("H", "K")]
    got = [(q, s) for q, s in got if s is not None and s >= CAUSE_SHARE]
    return ", ".join("%s %s" % (q, _pct(s)) for q, s in got)


def face_diagnosis(finest, coarsest, knots):
    """Causes of a face's error named from its records (module docstring).

    finest, coarsest: the level records (one per pattern) of the finest and coarsest
    levels; knots: :func:`knot_structure` of the region at the finest level. Returns
    dict(causes [short names], text (one line), evidence).
    """
    causes, words = [], []
    if all(r.get("n_retained") == 0 for r in finest):
        causes.append("every vertex masked")
        words.append(finest[0]["reasons"]["eps_H"])
    for q in ("H", "K"):
        if all(r.get("eps_" + q) is None and r.get("n_retained") for r in finest) and any(
                r.get("%s_reference_negligible" % q) for r in finest):
            causes.append("reference quasi-zero (%s)" % q)
            words.append("%s reference zero or quasi-zero, no relative error" % q)
    hk_max = _worst(finest, ("h_kappa", "max"))
    under = _worst(finest, ("h_kappa", "area_fraction_under_resolved"))
    s = _shares(finest, "under_resolved")
    if s:
        causes.append("resolution")
        words.append("resolution: h kappa_max up to %.2g; the %s of the area above %.1f carries %s of the "
                     "squared error" % (hk_max, _pct(under), UNDER_RESOLVED, s))
    s = _shares(finest, "steep_variation")
    if s:
        step = max(_worst(finest, ("variation", q, "max_step_over_rms")) or 0.0 for q in ("H", "K"))
        causes.append("curvature variation")
        words.append("curvature variation (resolution of the curvature field): the BRep H or K changes by up "
                     "to %.1f times its RMS between neighbouring vertices; the vertices where it changes by "
                     "more than its RMS carry %s of the squared error" % (step, s))
    asp = _worst(finest, ("panel_aspect", "p95"))
    s = _shares(finest, "stretched_panels")
    if s:
        causes.append("panel aspect")
        words.append("panel aspect: p95 %.0f : 1; panels above %.0f : 1 carry %s of the squared error"
                     % (asp, HIGH_ASPECT, s))
    n_c1 = knots["u"]["c1_lines"] + knots["v"]["c1_lines"]
    n_close = len(knots["u"]["close_pairs"]) + len(knots["v"]["close_pairs"])
    s = _shares(finest, "knot_lines")
    if s:
        causes.append("knot lines")
        words.append("knot lines: %d C1 line(s) and %d close knot pair(s) inside the region, their two-rings "
                     "carry %s of the squared error" % (n_c1, n_close, s))
    spans = max(knots["u"]["spans_per_panel"], knots["v"]["spans_per_panel"])
    if spans > 1.0:
        causes.append("knot spans finer than panels")
        words.append("%.1f knot spans per panel" % spans)
    stuck = [q for q in ("H", "K") if any(
        a.get("eps_" + q) is not None and b.get("eps_" + q) is not None and a["eps_" + q] >= b["eps_" + q]
        for a, b in zip(finest, coarsest)) and finest[0]["panels"] > coarsest[0]["panels"]]
    if stuck:
        causes.append("not refining")
        words.append("%s not below the %dx%d error" % (" and ".join(stuck), coarsest[0]["panels"],
                                                       coarsest[0]["panels"]))
    loc = [(q, _worst(finest, ("worst_1pct", q))) for q in ("H", "K")]
    loc = [(q, s) for q, s in loc if s is not None and s >= LOCALIZED_SHARE]
    if loc:
        causes.append("localized")
        words.append("the worst 1 %% of the area carries %s of the squared error"
                     % ", ".join("%s %s" % (q, _pct(s)) for q, s in loc))
    n_c0 = knots["u"]["creases"] + knots["v"]["creases"]
    if n_c0:
        words.append("%d crease(s) on grid lines, masked" % n_c0)
    evidence = {"h_kappa_max": hk_max, "under_resolved_area": under, "panel_aspect_p95": asp,
                "c1_lines": n_c1, "close_knot_pairs": n_close, "creases": n_c0, "knot_spans_per_panel": spans}
    missing = [k for k, v in evidence.items() if v is None]
    if missing:
        evidence["reasons"] = dict.fromkeys(missing, "no retained vertex (or no finite panel) at the finest level")
    return {"causes": causes, "text": "; ".join(words) if words else "no limiting effect measured",
            "evidence": evidence}
