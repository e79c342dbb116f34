"""Same-face BRep-to-mesh curvature recovery (paper section 5.2, eq:sameface_error).

For one BRep face, a structured grid of N x N panels is laid over an inset parameter
rectangle; the mesh vertices are placed exactly at S(u, v) (no projection), so the mesh
and the BRep share their sampled physical points and only the curvature recovery and the
triangle connectivity differ. Both triangulations of every grid are compared:

* ``consistent``: every quad is split along the same diagonal (i+1, j)-(i, j+1);
* ``alternating``: the diagonal alternates in a checkerboard ((i + j) odd uses (i, j)-(i+1, j+1)).

The recovered H, K (mesh backend, Rusinkiewicz) are compared with the direct BRep H, K at
the same vertices on a common mask: the two-ring strict interior (no boundary or crease
vertex within two edges, see below) with finite, regular values of both H and K from both
realizations. With delta = x_h - x_BRep and both vectors zeroed outside the mask,

    eps_X = sqrt(delta^T M delta / x_BRep^T M x_BRep),  X in {H, K}     (eq:sameface_error)

where M is the consistent P1 mass matrix of the physical triangles,
M_ij = A_t/12 (1 + delta_ij) summed over triangles t. One global sign of the recovered H
is chosen by its M-weighted correlation with the BRep H; K needs none.

Creases (C0 knot lines). A knot line of multiplicity >= degree inside the region is a line
where the surface is only C0: its tangent plane may turn there (DTMB 5415 face 1: up to
36 degrees), so it is a sharp edge inside the face and H, K have no pointwise value on it.
With ``align_creases`` (default) the grid lines of each direction are placed so that every
such line is a grid line: the parameter interval is cut at the creases and each piece gets
a share of the N panels proportional to its length (largest remainder, at least one panel),
uniform inside the piece. No triangle then straddles a crease, the mesh interpolates the
crease exactly, and the vertices on crease rows are treated as boundary vertices of the
smooth pieces in the two-ring mask (vertices within two edges of a crease row are excluded,
exactly as next to the face boundary). The grid is still N x N, structured, and its
vertices are still exact points S(u, v) of the unchanged face. A level whose N panels are
fewer than the pieces cannot place every crease on a grid line: its records are null with
that reason (:func:`unavailable_level`). Without ``align_creases`` the grid is uniform and
only the face boundary is masked.

Diagnostic ``eps_*_smooth``: additionally without the vertices whose two-ring (grid rows
i-2 .. i+2) reaches a knot line below C2 (C1 lines, where H and K jump but the surface is
tangent-continuous); equal to eps_H, eps_K on a face without such lines.

Every null value of a record has its reason in the record's ``reasons``; each face has a
diagnosis (:mod:`.sameface_diagnosis`); the document names the headline face (largest area)
and the largest-|K| face (:mod:`.sameface_headline`).

Inset region: an untrimmed face (its trimmed domain is its parameter rectangle) uses its
ParameterRange shrunk by ``inset`` (default 5 %) of each parameter range at every side.
A trimmed face uses the largest axis-parallel rectangle found inside its trimmed domain
(on a RASTER x RASTER raster of the parameter range, shrunk by one raster cell), shrunk
by the same inset fraction of that rectangle's ranges; every grid vertex of every level is
then checked to lie inside the trimmed domain.
"""
import numpy as np

from ..core.errors import InputError
from ..core.progress import null_progress, sub_progress
from ..core.writers import json_safe
from .sameface_grid import (DEFAULT_INSET, INTERIOR_RINGS, NEGLIGIBLE_H, NEGLIGIBLE_K,  # noqa: F401
                            PATTERNS, RASTER, SAMEFACE_LEVELS, grid_lines, grid_parameters, grid_triangles,
                            h_sign_alignment, mesh_edges, p1_mass_matrix, panel_split, relative_l2_error,
                            strict_interior, triangle_areas)
from .sameface_region import _inside_function, abs_K_integral, inset_rectangle, largest_rectangle  # noqa: F401


# ---------------------------------------------------------------------------------------------
# the comparison


def _curvature_function(curvature):
    if curvature is not None:
        return curvature
    from ..mesh.curvature import vertex_curvature
    return vertex_curvature


def _field(result, name):
    """Attribute or key `name` of a curvature result (named tuple, dataclass or dict)."""
    if isinstance(result, dict):
        return np.asarray(result[name], dtype=float)
    return np.asarray(getattr(result, name), dtype=float)


def _abs_stats(d):
    if d.size == 0:
        return None, None
    a = np.abs(d)
    return float(np.median(a)), float(np.percentile(a, 95))


def crease_lines(evaluator, rect):
    """(u_creases, v_creases): knot lines strictly inside rect where the surface is only C0
    (multiplicity >= degree; the tangent plane may turn there), each (k,) float."""
    return evaluator.continuity_breaks(min_continuity=1, urange=rect[:2], vrange=rect[2:])


def break_rings(u_lines, v_lines, breaks, rings=INTERIOR_RINGS):
    """((n_u+1) (n_v+1),) bool: grid vertices whose `rings`-ring reaches a break line.

    u_lines (n_u+1,), v_lines (n_v+1,): the grid lines; breaks: (u_breaks, v_breaks),
    parameter lines where the surface is less smooth than C^2 (H and K jump there). Row i
    is flagged when a u break b satisfies u_{i-rings} <= b <= u_{i+rings} (indices clipped
    to the grid), i.e. lies in the parameter span its curvature stencil covers; likewise v.
    """
    def flagged(lines, b):
        lines = np.asarray(lines, dtype=float)
        b = np.asarray(b, dtype=float)
        if b.size == 0:
            return np.zeros(len(lines), dtype=bool)
        idx = np.arange(len(lines))
        lo = lines[np.clip(idx - rings, 0, len(lines) - 1)]
        hi = lines[np.clip(idx + rings, 0, len(lines) - 1)]
        return ((lo[:, None] <= b[None, :]) & (b[None, :] <= hi[:, None])).any(axis=1)
    fu, fv = flagged(u_lines, breaks[0]), flagged(v_lines, breaks[1])
    return (fu[:, None] | fv[None, :]).ravel()


def compare_on_grid(evaluator, rect, n, pattern, curvature=None, align_creases=True):
    """One same-face comparison: grid n x n over rect, one diagonal pattern.

    evaluator: SurfaceEvaluator of the face. align_creases: C0 knot lines on grid lines and
    their rows masked like the boundary (module docstring). Returns a dict with panels,
    pattern, counts, eps_H, eps_K (fractions, eq:sameface_error), the H sign used, and
    median / 95th-percentile absolute errors of H (1/length) and K (1/length^2) on the
    retained vertices. H_reference_negligible / K_reference_negligible flag a quasi-zero
    reference (RMS |H| d or |K| d^2 <= 1e-4, d the grid's diagonal); its relative error is
    then null. creases: the lines placed on grid rows; eps_H_smooth, eps_K_smooth: the same
    errors without the vertices whose two-ring reaches a knot line below C2 (c2_breaks) as
    well. masked: why vertices left the mask; the measures of :mod:`.sameface_diagnosis`;
    reasons: {key: why its value is null} for every null value.
    Raises InputError when the creases outnumber the panels.
    """
    from ..brep.geometry.differential import surface_differentials
    from .sameface_diagnosis import close_pair_lines, knot_structure, level_measures
    curvature = _curvature_function(curvature)
    c_u, c_v = crease_lines(evaluator, rect) if align_creases else (np.empty(0), np.empty(0))
    ul, iu = grid_lines(rect[0], rect[1], n, c_u)
    vl, iv = grid_lines(rect[2], rect[3], n, c_v)
    uu, vv = np.meshgrid(ul, vl, indexing="ij")
    u, v = uu.ravel(), vv.ravel()
    seeds = np.zeros((n + 1, n + 1), dtype=bool)
    seeds[iu, :] = True
    seeds[:, iv] = True
    der = evaluator.derivatives(u, v)
    ref = surface_differentials(der, evaluator.orientation_sign)
    V = np.asarray(der[0], dtype=float)
    T = grid_triangles(n, pattern, flip=evaluator.orientation_sign < 0)
    rec = curvature(V, T)
    H_h, K_h = _field(rec, "H"), _field(rec, "K")
    interior = strict_interior(T, len(V), seeds=seeds.ravel())
    finite = np.isfinite(ref.H) & np.isfinite(ref.K) & np.isfinite(H_h) & np.isfinite(K_h)
    mask = interior & ref.regular & finite
    masked = {"boundary_or_crease_rings": int((~interior).sum()),
              "irregular_brep_points": int((interior & ~ref.regular).sum()),
              "non_finite_curvature": int((interior & ref.regular & ~finite).sum())}
    M = p1_mass_matrix(V, T)
    sign = h_sign_alignment(H_h, ref.H, M, mask)
    H_h = sign * H_h
    u_br, v_br = evaluator.continuity_breaks(min_continuity=2, urange=rect[:2], vrange=rect[2:])
    size = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))
    rms_H, rms_K = _rms(ref.H, M, mask), _rms(ref.K, M, mask)
    smooth = mask & ~break_rings(ul, vl, (u_br, v_br))
    out = {"panels": int(n), "pattern": pattern, "n_vertices": int(len(V)), "n_triangles": int(len(T)),
           "n_retained": int(mask.sum()), "masked": masked, "H_sign": int(sign),
           "rms_H_ref": rms_H, "rms_K_ref": rms_K,
           "H_reference_negligible": bool(rms_H is None or rms_H * size <= NEGLIGIBLE_H),
           "K_reference_negligible": bool(rms_K is None or rms_K * size ** 2 <= NEGLIGIBLE_K),
           "creases": {"u": c_u, "v": c_v}, "c2_breaks": {"u": u_br, "v": v_br},
           "n_retained_smooth": int(smooth.sum())}
    reasons = {}
    if not mask.any():
        why = ("every vertex masked: %d of %d within two edges of the boundary or a crease row, %d at "
               "irregular BRep points, %d with non-finite curvature"
               % (masked["boundary_or_crease_rings"], len(V), masked["irregular_brep_points"],
                  masked["non_finite_curvature"]))
    for q, x_h, x_ref, rms, scale in (("H", H_h, ref.H, rms_H, size), ("K", K_h, ref.K, rms_K, size ** 2)):
        d = x_h - x_ref
        med, p95 = _abs_stats(d[mask])
        out["median_abs_error_" + q], out["p95_abs_error_" + q] = med, p95
        if not mask.any():
            for key in ("eps_" + q, "eps_%s_smooth" % q, "median_abs_error_" + q, "p95_abs_error_" + q,
                        "rms_%s_ref" % q):
                reasons[key] = why
            out["eps_" + q] = out["eps_%s_smooth" % q] = None
            continue
        if rms == 0.0:
            zero = "the BRep %s is identically zero on the %d retained vertices" % (q, int(mask.sum()))
        elif out["%s_reference_negligible" % q]:
            zero = ("the BRep %s reference is quasi-zero: RMS |%s| d%s = %.3g <= %g (d the grid diagonal), "
                    "so its relative error measures nothing; the absolute errors are kept"
                    % (q, q, "" if q == "H" else "^2", rms * scale, NEGLIGIBLE_H if q == "H" else NEGLIGIBLE_K))
        else:
            zero = None
        if zero:
            out["eps_" + q] = out["eps_%s_smooth" % q] = None
            reasons["eps_" + q] = reasons["eps_%s_smooth" % q] = zero
            continue
        out["eps_" + q] = relative_l2_error(x_h, x_ref, M, mask)
        out["eps_%s_smooth" % q] = relative_l2_error(x_h, x_ref, M, smooth) if smooth.any() else None
        if out["eps_%s_smooth" % q] is None:
            reasons["eps_%s_smooth" % q] = (
                "no retained vertex is outside the two-rings of the %d knot line(s) below C2"
                % (len(u_br) + len(v_br)) if not smooth.any() else
                "the BRep %s is identically zero away from the knot lines below C2" % q)
    knots = knot_structure(evaluator, rect, n)
    band = break_rings(ul, vl, (np.r_[u_br, close_pair_lines(knots)[0]], np.r_[v_br, close_pair_lines(knots)[1]]))
    w = np.asarray(M.sum(axis=1)).ravel()
    meas = level_measures(V, n, ref.k1, ref.k2, H_h - ref.H, K_h - ref.K, w, mask, band, ref.H, ref.K)
    for key, val in meas.items():
        if val is None:
            reasons[key] = why
        elif key in ("worst_1pct", "error_share", "variation"):
            for q in ("H", "K"):
                if out["eps_" + q] is None:
                    val[q] = None
                    val.setdefault("reasons", {})[q] = "eps_%s is null: %s" % (q, reasons["eps_" + q])
                elif key == "worst_1pct" and val[q] is None:
                    val.setdefault("reasons", {})[q] = "the %s error is zero on every retained vertex" % q
                elif key in ("error_share", "variation") and any(x is None for x in val[q].values()):
                    val[q] = None
                    val.setdefault("reasons", {})[q] = "the %s error is zero on every retained vertex" % q
    out.update(meas)
    out["knots"] = knots
    out["reasons"] = reasons
    return out


def _rms(x, M, mask):
    """Mass-weighted RMS of x over the mask (the scale of eq:sameface_error's denominator)."""
    m = np.asarray(mask, dtype=bool)
    xr = np.where(m, x, 0.0)
    w = float(np.ones(len(x)) @ (M @ m.astype(float)))
    return float(np.sqrt(max(float(xr @ (M @ xr)), 0.0) / w)) if w > 0 else None


def error_ratios(levels):
    """Finest-to-coarsest error ratios eps(N_max) / eps(N_min) per pattern and quantity, with
    reasons for the null ones (computed levels only)."""
    out = []
    levels = [r for r in levels if not r.get("unavailable")]
    for pattern in sorted({r["pattern"] for r in levels}, key=PATTERNS.index):
        recs = sorted((r for r in levels if r["pattern"] == pattern), key=lambda r: r["panels"])
        if len(recs) < 2:
            continue
        lo, hi = recs[0], recs[-1]
        row = {"pattern": pattern, "fine": hi["panels"], "coarse": lo["panels"], "reasons": {}}
        for q in ("eps_H", "eps_K"):
            a, b = hi[q], lo[q]
            row[q + "_ratio"] = (a / b) if (a is not None and b) else None
            if row[q + "_ratio"] is None:
                bad = hi if a is None else lo
                row["reasons"][q + "_ratio"] = (
                    "%s is null at %dx%d: %s" % (q, bad["panels"], bad["panels"], bad["reasons"][q])
                    if bad[q] is None else "%s is zero at %dx%d" % (q, lo["panels"], lo["panels"]))
        out.append(row)
    return out


def unavailable_level(n, pattern, reason):
    """The record of a level that cannot be compared: every value null with its reason."""
    keys = ("eps_H", "eps_K", "eps_H_smooth", "eps_K_smooth", "n_retained")
    return dict({"panels": int(n), "pattern": pattern, "unavailable": reason,
                 "reasons": dict.fromkeys(keys, reason)}, **dict.fromkeys(keys))


def sameface_face(face, levels=SAMEFACE_LEVELS, patterns=PATTERNS, inset=DEFAULT_INSET, curvature=None,
                  progress=None, number=None, align_creases=True):
    """Same-face study of one Part.Face: one record per level and pattern (see module docstring).

    Returns dict(face, surface_kind, area, abs_K_integral (midpoint estimate over the trimmed
    domain, :func:`abs_K_integral`), rect..., creases {u, v}, levels [records of
    compare_on_grid, or of :func:`unavailable_level` for a level whose panels are fewer
    than the crease-cut pieces], ratios [error_ratios], finer_below_coarsest {eps_H, eps_K},
    diagnosis (:func:`.sameface_diagnosis.face_diagnosis`), reasons).
    A face with no comparable level is returned with a 'skipped' reason.
    """
    from ..brep.geometry.surface_eval import SurfaceEvaluator
    from .sameface_diagnosis import face_diagnosis, knot_structure
    progress = progress or null_progress
    levels = sorted(int(n) for n in levels)
    ev = SurfaceEvaluator.for_face(face)
    area, why_area = face_area(face)
    out = {"face": number, "surface_kind": ev.kind, "area": area,
           "orientation_sign": ev.orientation_sign, "reasons": {}}
    if area is None:
        out["reasons"]["area"] = why_area
    inside = _inside_function(face)
    out["abs_K_integral"] = abs_K_integral(face, ev, inside)
    if out["abs_K_integral"] is None:
        out["reasons"]["abs_K_integral"] = "no regular midpoint of the raster lies inside the trimmed domain"
    creases = (lambda rect: crease_lines(ev, rect)) if align_creases else None
    try:
        region = inset_rectangle(face, inset, check_levels=levels, creases=creases, inside=inside)
        if not region["checked_levels"]:
            raise InputError("no level can be compared: %s"
                             % "; ".join(sorted(set(region["level_reasons"].values()))))
    except InputError as exc:
        out.update({"skipped": " ".join(str(exc).split()), "levels": []})
        return out
    c_u, c_v = creases(region["rect"]) if align_creases else (np.empty(0), np.empty(0))
    records = []
    steps = len(levels) * len(patterns)
    for k, (n, pattern) in enumerate((n, p) for n in levels for p in patterns):
        progress(k / steps, "face %s: %dx%d %s" % (number, n, n, pattern))
        if n not in region["checked_levels"]:
            records.append(unavailable_level(n, pattern, region["level_reasons"][n]))
            continue
        records.append(compare_on_grid(ev, region["rect"], n, pattern, curvature, align_creases))
    computed = [r for r in records if not r.get("unavailable")]
    ratios = error_ratios(records)
    below = {}
    for q in ("eps_H", "eps_K"):
        vals = [r[q + "_ratio"] for r in ratios]
        below[q] = None if not vals or any(x is None for x in vals) else bool(all(x < 1.0 for x in vals))
        if below[q] is None:
            out["reasons"]["finer_below_coarsest." + q] = (
                "fewer than two levels compared" if not vals else
                "; ".join("%s: %s" % (r["pattern"], r["reasons"][q + "_ratio"]) for r in ratios
                          if r[q + "_ratio"] is None))
    if any(v is None for v in below.values()):
        below["reasons"] = {q: out["reasons"].pop("finer_below_coarsest." + q) for q in ("eps_H", "eps_K")
                            if below[q] is None}
    fine_n, coarse_n = max(r["panels"] for r in computed), min(r["panels"] for r in computed)
    finest = [r for r in computed if r["panels"] == fine_n]
    coarsest = [r for r in computed if r["panels"] == coarse_n]
    out.update(region)
    out.update({"creases": {"u": c_u, "v": c_v}, "levels": records, "ratios": ratios,
                "finer_below_coarsest": below,
                "diagnosis": face_diagnosis(finest, coarsest, knot_structure(ev, region["rect"], fine_n))})
    for key in ("checked_levels", "level_reasons"):
        out.pop(key)
    return out


def sameface_study(source, faces=None, levels=SAMEFACE_LEVELS, patterns=PATTERNS, inset=DEFAULT_INSET,
                   curvature=None, progress=None, abs_K_share=None, align_creases=True):
    """Same-face BRep-to-mesh recovery study of a BRep (path, Part.Shape or FreeCAD object).

    faces: 1-based face numbers (None: all faces). A face whose study cannot be run (no
    rectangle inside its trimmed domain, creases outnumbering the panels of every level) is
    listed with a 'skipped' reason. abs_K_share: optional {face: share of the hull's
    integral of |K|} (e.g. from :func:`abs_K_shares`); without it the shares are the
    faces' midpoint estimates (:func:`abs_K_integral`). align_creases: C0 knot lines on grid
    lines, their rows masked like the boundary (module docstring; False: the uniform grid).
    Returns a JSON-safe dict: study, input, settings, faces [sameface_face records],
    headline_face (largest area), largest_K_face (largest |K| share), table (flat rows);
    every null value of a record has its reason in the record's ``reasons``.
    """
    from ..brep.reading.loading import load_brep
    from .sameface_diagnosis import diagnosis_settings
    from .sameface_headline import face_shares, headline_face, largest_K_face
    progress = progress or null_progress
    patterns = tuple(patterns)
    for p in patterns:
        if p not in PATTERNS:
            raise InputError("unknown diagonal pattern %r (choose from %s)" % (p, ", ".join(PATTERNS)))
    levels = sorted(int(n) for n in levels)
    if not levels or levels[0] < 6:
        raise InputError("same-face levels need at least 6 panels (the two-ring interior of a "
                         "coarser grid is empty), got %r" % (levels,))
    if not 0.0 <= float(inset) < 0.5:
        raise InputError("the inset must be a fraction in [0, 0.5), got %r" % (inset,))
    brep = load_brep(source, faces)
    out_faces = []
    nf = len(brep.faces)
    for k, (number, face) in enumerate(brep.faces):
        sub = sub_progress(progress, k / nf, (k + 1) / nf)
        try:
            rec = sameface_face(face, levels, patterns, inset, curvature, sub, number, align_creases)
        except (InputError,) + occ_errors() as exc:
            area, why_area = face_area(face)
            why = " ".join(str(exc).split()) or type(exc).__name__
            if not isinstance(exc, InputError):
                why = "OpenCascade failed on the face: %s" % why
            rec = {"face": number, "skipped": why, "levels": [], "area": area, "abs_K_integral": None,
                   "reasons": {"abs_K_integral": "the face could not be set up: %s" % why}}
            if area is None:
                rec["reasons"]["area"] = why_area
        out_faces.append(rec)
    face_shares(out_faces, abs_K_share)
    progress(1.0, "same-face study done")
    table = []
    for f in out_faces:
        for r in f["levels"]:
            row = dict(face=f["face"], **{k: r[k] for k in ("panels", "pattern", "eps_H", "eps_K", "n_retained")})
            why = {k: r["reasons"][k] for k in ("eps_H", "eps_K", "n_retained") if row[k] is None}
            if why:
                row["reasons"] = why
            table.append(row)
    info = dict(brep.info)
    missing = [k for k, v in info.items() if v is None]
    if missing:
        why = ("the input is a shape in memory, not a file" if info.get("path") is None
               else "not recorded by the BRep reader")
        info["reasons"] = dict.fromkeys(missing, why)
    doc = {"study": "sameface", "input": info, "units": brep.units,
           "settings": {"levels": levels, "patterns": list(patterns), "inset": float(inset),
                        "interior_rings": INTERIOR_RINGS, "align_creases": bool(align_creases),
                        "mask": ("two-ring strict interior of the boundary%s with finite, regular H and K "
                                 "of both realizations" % (" and of the crease rows (C0 knot lines placed on "
                                                           "grid lines)" if align_creases else "")),
                        "norm": "consistent P1 mass matrix on the physical triangles",
                        "H_sign": "one global sign of the recovered H by M-weighted correlation with the BRep H",
                        "faces_selected": None if faces is None else list(faces),
                        "diagnosis": diagnosis_settings()},
           "faces": out_faces, "headline_face": headline_face(out_faces, faces is not None),
           "largest_K_face": largest_K_face(out_faces), "table": table}
    if faces is None:
        doc["settings"]["reasons"] = {"faces_selected": "no --faces: every face of the shape"}
    return json_safe(doc)


def occ_errors():
    """The exception types FreeCAD raises for a failing OpenCascade operation on a damaged face."""
    from ..freecad_env import import_freecad
    FreeCAD = import_freecad()
    import Part
    return tuple({getattr(FreeCAD.Base, "FreeCADError", RuntimeError), getattr(Part, "OCCError", RuntimeError)})


def face_area(face):
    """(area, None) of a Part.Face, or (None, reason) when OpenCascade cannot compute it."""
    try:
        return float(face.Area), None
    except occ_errors() as exc:
        return None, "OpenCascade cannot compute the face's area (%s)" % (" ".join(str(exc).split()) or
                                                                         type(exc).__name__)


def abs_K_shares(assessment):
    """{face number: share of the hull's integral of |K| dA} from a BRep assessment's
    per-face records (provenance['faces'][i]['K_share'])."""
    rows = (assessment.provenance or {}).get("faces") or []
    return {int(r["face"]): r.get("K_share") for r in rows if "face" in r}
