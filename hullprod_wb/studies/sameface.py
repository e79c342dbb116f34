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
fewer than the pieces cannot place every crease on a grid line (InputError). Without
``align_creases`` the grid is uniform and only the face boundary is masked.

Diagnostic ``eps_*_smooth``: additionally without the vertices whose two-ring (grid rows
i-2 .. i+2) reaches a knot line below C2 (C1 lines, where H and K jump but the surface is
tangent-continuous); equal to eps_H, eps_K on a face without such lines.

Inset region: an untrimmed face (its trimmed domain is its parameter rectangle) uses its
ParameterRange shrunk by ``inset`` (default 5 %) of each parameter range at every side.
A trimmed face uses the largest axis-parallel rectangle found inside its trimmed domain
(on a RASTER x RASTER raster of the parameter range, shrunk by one raster cell), shrunk
by the same inset fraction of that rectangle's ranges; every grid vertex of every level is
then checked to lie inside the trimmed domain.
"""
import numpy as np
from scipy import sparse

from ..core.errors import InputError
from ..core.progress import null_progress
from ..core.writers import json_safe

#: Grid levels (panels per parameter direction) of the paper's study.
SAMEFACE_LEVELS = (12, 24, 48)
#: Triangle-diagonal patterns.
PATTERNS = ("consistent", "alternating")
#: Inset of the parameter rectangle at each side, as a fraction of each parameter range.
DEFAULT_INSET = 0.05
#: Raster resolution used to find the largest rectangle inside a trimmed domain.
RASTER = 96
#: A reference whose RMS, made dimensionless with the grid's diagonal d (|H| d, |K| d^2),
#: is at most this is quasi-zero: its relative error is reported but flagged (paper's
#: default h_f = k_f = 1e-4 as the quasi-zero scale).
NEGLIGIBLE_H = 1e-4
NEGLIGIBLE_K = 1e-4
#: Rings around boundary vertices excluded from the comparison (two-ring strict interior).
INTERIOR_RINGS = 2


# ---------------------------------------------------------------------------------------------
# structured grid


def panel_split(lengths, n):
    """(k,) int panels per piece of a parameter interval cut into pieces of the given (k,)
    float lengths: proportional to the lengths, at least one each, summing to n (largest
    remainder). Raises InputError when n < k."""
    L = np.asarray(lengths, dtype=float)
    k, n = len(L), int(n)
    if k > n:
        raise InputError("%d panels cannot place a grid line on each of the %d crease lines "
                         "inside the region" % (n, k - 1))
    ideal = n * L / L.sum()
    count = np.maximum(1, np.floor(ideal).astype(int))
    while count.sum() < n:                      # k iterations at most
        count[np.argmax(ideal - count)] += 1
    while count.sum() > n:
        count[np.argmax(np.where(count > 1, count - ideal, -np.inf))] -= 1
    return count


def grid_lines(lo, hi, n, creases=()):
    """(n+1,) float parameter lines over [lo, hi] with every crease in (lo, hi) on a line,
    and the (k,) int indices of the crease lines.

    Without creases: np.linspace(lo, hi, n + 1). With creases, [lo, hi] is cut at them and
    piece p gets :func:`panel_split` panels, uniform inside the piece.
    """
    lo, hi = float(lo), float(hi)
    c = np.unique(np.asarray(creases, dtype=float))
    c = c[(c > lo) & (c < hi)]
    if c.size == 0:
        return np.linspace(lo, hi, int(n) + 1), np.empty(0, dtype=np.int64)
    edges = np.r_[lo, c, hi]
    count = panel_split(np.diff(edges), n)
    lines = np.concatenate([np.linspace(edges[p], edges[p + 1], count[p] + 1)[:-1]
                            for p in range(len(count))] + [[hi]])
    return lines, np.cumsum(count)[:-1].astype(np.int64)


def grid_parameters(rect, n, creases=None):
    """(u, v) of the (n+1)^2 grid vertices over rect = (u0, u1, v0, v1), each ((n+1)^2,) float.

    Vertex (i, j) (i along u, j along v) has index i (n+1) + j. creases: None (uniform grid)
    or (u_creases, v_creases), parameter values placed on grid lines (:func:`grid_lines`).
    """
    u0, u1, v0, v1 = (float(x) for x in rect)
    cu, cv = (), ()
    if creases is not None:
        cu, cv = creases
    ul, _ = grid_lines(u0, u1, n, cu)
    vl, _ = grid_lines(v0, v1, n, cv)
    uu, vv = np.meshgrid(ul, vl, indexing="ij")
    return uu.ravel(), vv.ravel()


def grid_triangles(n, pattern="consistent", flip=False):
    """(2 n^2, 3) int triangles of an n x n panel grid (vertex (i, j) -> i (n+1) + j).

    The grid of :func:`hullprod_wb.examples.analytic_meshes.grid_faces`: quad corners
    a = (i, j), b = (i+1, j), c = (i+1, j+1), d = (i, j+1) are counter-clockwise in (u, v), so
    the normals follow S_u x S_v (reversed when flip). 'consistent' splits every quad along
    b-d, 'alternating' along b-d and a-c in a checkerboard.
    """
    from ..examples.analytic_meshes import grid_faces
    if pattern not in PATTERNS:
        raise InputError("unknown diagonal pattern %r (choose from %s)" % (pattern, ", ".join(PATTERNS)))
    if int(n) < 1:
        raise InputError("a grid needs at least one panel per direction, got %r" % (n,))
    tri = grid_faces(int(n) + 1, int(n) + 1, pattern)
    if flip:
        tri = tri[:, [0, 2, 1]]
    return np.ascontiguousarray(tri, dtype=np.int64)


# ---------------------------------------------------------------------------------------------
# mesh operators


def mesh_edges(triangles):
    """Unique undirected edges (k, 2) int and how many triangles use each (k,) int."""
    T = np.asarray(triangles, dtype=np.int64)
    e = np.sort(np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]]), axis=1)
    return np.unique(e, axis=0, return_counts=True)


def strict_interior(triangles, n_vertices, rings=INTERIOR_RINGS, seeds=None):
    """(n,) bool: vertices with no boundary (or seed) vertex within `rings` edges.

    Boundary vertices lie on an edge used by one triangle only; seeds: optional (n,) bool of
    further vertices treated like boundary vertices (crease rows). The excluded set is their
    union dilated `rings` times along the edge graph (rings = 2: the two-ring strict
    interior, whose curvature stencils never see an incomplete neighbourhood).
    """
    edges, count = mesh_edges(triangles)
    near = np.zeros(n_vertices, dtype=bool)
    near[edges[count == 1].ravel()] = True
    if seeds is not None:
        near |= np.asarray(seeds, dtype=bool)
    n_edges = len(edges)
    A = sparse.coo_matrix((np.ones(2 * n_edges), (np.r_[edges[:, 0], edges[:, 1]],
                                                  np.r_[edges[:, 1], edges[:, 0]])),
                          shape=(n_vertices, n_vertices)).tocsr()
    for _ in range(int(rings)):
        near = near | (A @ near.astype(float) > 0)
    used = np.zeros(n_vertices, dtype=bool)
    used[np.asarray(triangles).ravel()] = True
    return used & ~near


def triangle_areas(vertices, triangles):
    """(m,) float physical areas |(x1 - x0) x (x2 - x0)| / 2."""
    V = np.asarray(vertices, dtype=float)
    T = np.asarray(triangles, dtype=np.int64)
    c = np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])
    return 0.5 * np.sqrt(np.einsum("ij,ij->i", c, c))


def p1_mass_matrix(vertices, triangles):
    """Consistent P1 mass matrix (n, n) scipy.sparse.csr: M_ij = sum_t A_t/12 (1 + delta_ij)."""
    T = np.asarray(triangles, dtype=np.int64)
    A = triangle_areas(vertices, T)
    rows = np.repeat(T, 3, axis=1).ravel()          # (a a a b b b c c c)
    cols = np.tile(T, (1, 3)).ravel()               # (a b c a b c a b c)
    local = np.array([2.0, 1.0, 1.0, 1.0, 2.0, 1.0, 1.0, 1.0, 2.0]) / 12.0
    vals = (A[:, None] * local[None, :]).ravel()
    n = len(vertices)
    return sparse.coo_matrix((vals, (rows, cols)), shape=(n, n)).tocsr()


def relative_l2_error(x_h, x_ref, M, mask):
    """eps = sqrt(d^T M d / x_ref^T M x_ref) with both vectors zeroed outside mask
    (eq:sameface_error); None when the reference norm is zero."""
    m = np.asarray(mask, dtype=bool)
    xr = np.where(m, x_ref, 0.0)
    d = np.where(m, x_h, 0.0) - xr
    den = float(xr @ (M @ xr))
    num = float(d @ (M @ d))
    if not den > 0.0:
        return None
    return float(np.sqrt(max(num, 0.0) / den))


def h_sign_alignment(H_h, H_ref, M, mask):
    """+1 or -1: sign of the M-weighted correlation sum(H_h M H_ref) over the mask."""
    m = np.asarray(mask, dtype=bool)
    a = np.where(m, H_h, 0.0)
    b = np.where(m, H_ref, 0.0)
    return -1 if float(a @ (M @ b)) < 0.0 else 1


# ---------------------------------------------------------------------------------------------
# the parameter rectangle


def _inside_function(face):
    """Vectorised inside(u, v) -> bool for the face's trimmed domain, and its description.

    Uses the exact trimmed domain (p-curves); when it cannot be built, OpenCascade's
    per-point face classifier (Part.Face.isPartOfDomain).
    """
    from ..brep.trimmed_domain import TrimmedDomain
    try:
        domain = TrimmedDomain.from_face(face)
    except InputError as exc:
        def inside_occ(u, v):
            u = np.asarray(u, float).ravel()
            v = np.asarray(v, float).ravel()
            return np.array([bool(face.isPartOfDomain(float(a), float(b))) for a, b in zip(u, v)])
        return inside_occ, False, "OpenCascade face classifier (trim curves unusable: %s)" % exc

    def inside(u, v):
        u = np.asarray(u, float).ravel()
        v = np.asarray(v, float).ravel()
        out = np.zeros(u.size, dtype=bool)
        idx, lo, hi = domain.v_intervals(u)
        if idx.size:
            hit = (v[idx] >= lo) & (v[idx] <= hi)
            out[idx[hit]] = True
        return out
    return inside, bool(domain.is_rectangle), "trim-curve domain"


def largest_rectangle(grid):
    """Largest all-True axis-parallel rectangle of a (r, c) bool raster.

    Returns (i0, i1, j0, j1), inclusive row and column ranges, or None. Row-by-row
    maximal rectangle under a histogram (stack method), O(r c).
    """
    r, c = grid.shape
    heights = np.zeros(c, dtype=int)
    best, box = 0, None
    for i in range(r):
        heights = np.where(grid[i], heights + 1, 0)
        stack = []
        for j in range(c + 1):
            h = heights[j] if j < c else 0
            start = j
            while stack and stack[-1][1] >= h:
                start, hs = stack.pop()
                area = hs * (j - start)
                if area > best:
                    best, box = area, (i - hs + 1, i, start, j - 1)
            stack.append((start, h))
    return box


def inset_rectangle(face, inset=DEFAULT_INSET, check_levels=SAMEFACE_LEVELS, creases=None):
    """Parameter rectangle of the same-face grids for a Part.Face (see module docstring).

    creases: None or a callable rect -> (u_creases, v_creases) whose lines the checked grids
    place on grid lines (:func:`grid_parameters`). Returns dict(rect (u0, u1, v0, v1),
    base_rect, trimmed, method, inset). Raises InputError when no rectangle inside the
    trimmed domain is found.
    """
    if not 0.0 <= float(inset) < 0.5:
        raise InputError("the inset must be a fraction in [0, 0.5), got %r" % (inset,))
    U0, U1, V0, V1 = (float(x) for x in face.ParameterRange)
    if not (U1 > U0 and V1 > V0):
        raise InputError("the face has an empty parameter range %r" % ((U0, U1, V0, V1),))
    inside, is_rect, how = _inside_function(face)
    if is_rect:
        base = (U0, U1, V0, V1)
        method = "untrimmed face: parameter range"
    else:
        du, dv = (U1 - U0) / RASTER, (V1 - V0) / RASTER
        uc, vc = grid_parameters((U0 + du / 2, U1 - du / 2, V0 + dv / 2, V1 - dv / 2), RASTER - 1)
        raster = inside(uc, vc).reshape(RASTER, RASTER)
        box = largest_rectangle(raster)
        if box is None or box[1] - box[0] < 2 or box[3] - box[2] < 2:
            raise InputError("no parameter rectangle found inside the face's trimmed domain")
        i0, i1, j0, j1 = box
        # raster cells i0..i1 cover [U0 + i0 du, U0 + (i1+1) du]; drop one cell each side
        base = (U0 + (i0 + 1) * du, U0 + i1 * du, V0 + (j0 + 1) * dv, V0 + j1 * dv)
        method = "trimmed face: largest rectangle inside the %s" % how
    u0, u1, v0, v1 = base
    rect = (u0 + inset * (u1 - u0), u1 - inset * (u1 - u0), v0 + inset * (v1 - v0), v1 - inset * (v1 - v0))
    if not is_rect:
        lines = None if creases is None else creases(rect)
        for n in check_levels:
            u, v = grid_parameters(rect, n, lines)
            if not inside(u, v).all():
                raise InputError("the inset rectangle %r of a trimmed face leaves the trimmed domain "
                                 "at the %dx%d level" % (rect, n, n))
    return {"rect": rect, "base_rect": base, "trimmed": not is_rect, "method": method,
            "inset": float(inset)}


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
    reference (RMS |H| d or |K| d^2 <= 1e-4, d the grid's diagonal). creases: the lines
    placed on grid rows; eps_H_smooth, eps_K_smooth: the same errors without the vertices
    whose two-ring reaches a knot line below C2 (c2_breaks) as well.
    """
    from ..brep.differential import surface_differentials
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
    mask = strict_interior(T, len(V), seeds=seeds.ravel()) & ref.regular
    mask &= np.isfinite(ref.H) & np.isfinite(ref.K) & np.isfinite(H_h) & np.isfinite(K_h)
    M = p1_mass_matrix(V, T)
    sign = h_sign_alignment(H_h, ref.H, M, mask)
    H_h = sign * H_h
    eps_H = relative_l2_error(H_h, ref.H, M, mask)
    eps_K = relative_l2_error(K_h, ref.K, M, mask)
    med_H, p95_H = _abs_stats((H_h - ref.H)[mask])
    med_K, p95_K = _abs_stats((K_h - ref.K)[mask])
    u_br, v_br = evaluator.continuity_breaks(min_continuity=2, urange=rect[:2], vrange=rect[2:])
    size = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))
    rms_H, rms_K = _rms(ref.H, M, mask), _rms(ref.K, M, mask)
    smooth = mask & ~break_rings(ul, vl, (u_br, v_br))
    return {"panels": int(n), "pattern": pattern, "n_vertices": int(len(V)), "n_triangles": int(len(T)),
            "n_retained": int(mask.sum()), "eps_H": eps_H, "eps_K": eps_K, "H_sign": int(sign),
            "median_abs_error_H": med_H, "p95_abs_error_H": p95_H,
            "median_abs_error_K": med_K, "p95_abs_error_K": p95_K,
            "rms_H_ref": rms_H, "rms_K_ref": rms_K,
            "H_reference_negligible": bool(rms_H is None or rms_H * size <= NEGLIGIBLE_H),
            "K_reference_negligible": bool(rms_K is None or rms_K * size ** 2 <= NEGLIGIBLE_K),
            "creases": {"u": c_u, "v": c_v}, "c2_breaks": {"u": u_br, "v": v_br},
            "n_retained_smooth": int(smooth.sum()),
            "eps_H_smooth": relative_l2_error(H_h, ref.H, M, smooth) if smooth.any() else None,
            "eps_K_smooth": relative_l2_error(K_h, ref.K, M, smooth) if smooth.any() else None}


def _rms(x, M, mask):
    """Mass-weighted RMS of x over the mask (the scale of eq:sameface_error's denominator)."""
    m = np.asarray(mask, dtype=bool)
    xr = np.where(m, x, 0.0)
    w = float(np.ones(len(x)) @ (M @ m.astype(float)))
    return float(np.sqrt(max(float(xr @ (M @ xr)), 0.0) / w)) if w > 0 else None


def error_ratios(levels):
    """Finest-to-coarsest error ratios eps(N_max) / eps(N_min) per pattern and quantity."""
    out = []
    for pattern in sorted({r["pattern"] for r in levels}, key=PATTERNS.index):
        recs = sorted((r for r in levels if r["pattern"] == pattern), key=lambda r: r["panels"])
        if len(recs) < 2:
            continue
        lo, hi = recs[0], recs[-1]
        row = {"pattern": pattern, "fine": hi["panels"], "coarse": lo["panels"]}
        for q in ("eps_H", "eps_K"):
            a, b = hi[q], lo[q]
            row[q + "_ratio"] = (a / b) if (a is not None and b) else None
        out.append(row)
    return out


def sameface_face(face, levels=SAMEFACE_LEVELS, patterns=PATTERNS, inset=DEFAULT_INSET, curvature=None,
                  progress=None, number=None, align_creases=True):
    """Same-face study of one Part.Face: one record per level and pattern (see module docstring).

    Returns dict(face, surface_kind, area, rect..., creases {u, v}, levels [records of
    compare_on_grid], ratios [error_ratios], finer_below_coarsest {eps_H, eps_K}).
    Raises InputError when a level has fewer panels than the crease-cut pieces.
    """
    from ..brep.surface_eval import SurfaceEvaluator
    progress = progress or null_progress
    levels = sorted(int(n) for n in levels)
    ev = SurfaceEvaluator.for_face(face)
    creases = (lambda rect: crease_lines(ev, rect)) if align_creases else None
    region = inset_rectangle(face, inset, check_levels=levels, creases=creases)
    c_u, c_v = creases(region["rect"]) if align_creases else (np.empty(0), np.empty(0))
    records = []
    steps = len(levels) * len(patterns)
    for k, (n, pattern) in enumerate((n, p) for n in levels for p in patterns):
        progress(k / steps, "face %s: %dx%d %s" % (number, n, n, pattern))
        records.append(compare_on_grid(ev, region["rect"], n, pattern, curvature, align_creases))
    ratios = error_ratios(records)
    below = {}
    for q in ("eps_H", "eps_K"):
        vals = [r[q + "_ratio"] for r in ratios]
        below[q] = None if not vals or any(x is None for x in vals) else bool(all(x < 1.0 for x in vals))
    out = {"face": number, "surface_kind": ev.kind, "area": float(face.Area),
           "orientation_sign": ev.orientation_sign}
    out.update(region)
    out.update({"creases": {"u": c_u, "v": c_v}, "levels": records, "ratios": ratios,
                "finer_below_coarsest": below})
    return out


def sameface_study(source, faces=None, levels=SAMEFACE_LEVELS, patterns=PATTERNS, inset=DEFAULT_INSET,
                   curvature=None, progress=None, abs_K_share=None, align_creases=True):
    """Same-face BRep-to-mesh recovery study of a BRep (path, Part.Shape or FreeCAD object).

    faces: 1-based face numbers (None: all faces). A face whose study cannot be run (no
    rectangle inside its trimmed domain, zero reference curvature) is listed with a
    'skipped' reason. abs_K_share: optional {face: share of the hull's integral of |K|}
    copied into the face records (e.g. from :func:`abs_K_shares`). align_creases: C0 knot
    lines on grid lines, their rows masked like the boundary (module docstring; False: the
    uniform grid). Returns a JSON-safe dict: study, input, settings, faces
    [sameface_face records], table (flat rows).
    """
    from ..brep.loading import load_brep
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
        sub = _sub_progress(progress, k / nf, (k + 1) / nf)
        try:
            rec = sameface_face(face, levels, patterns, inset, curvature, sub, number, align_creases)
        except InputError as exc:
            rec = {"face": number, "skipped": " ".join(str(exc).split()), "levels": []}
        if abs_K_share is not None and number in abs_K_share:
            rec["abs_K_share"] = abs_K_share[number]
        out_faces.append(rec)
    progress(1.0, "same-face study done")
    table = [dict(face=f["face"], **{k: r[k] for k in ("panels", "pattern", "eps_H", "eps_K",
                                                      "n_retained")})
             for f in out_faces for r in f["levels"]]
    doc = {"study": "sameface", "input": brep.info, "units": brep.units,
           "settings": {"levels": levels, "patterns": list(patterns), "inset": float(inset),
                        "interior_rings": INTERIOR_RINGS, "align_creases": bool(align_creases),
                        "mask": ("two-ring strict interior of the boundary%s with finite, regular H and K "
                                 "of both realizations" % (" and of the crease rows (C0 knot lines placed on "
                                                           "grid lines)" if align_creases else "")),
                        "norm": "consistent P1 mass matrix on the physical triangles (eq:sameface_error)",
                        "H_sign": "one global sign of the recovered H by M-weighted correlation with the BRep H"},
           "faces": out_faces, "table": table}
    return json_safe(doc)


def abs_K_shares(assessment):
    """{face number: share of the hull's integral of |K| dA} from a BRep assessment's
    per-face records (provenance['faces'][i]['K_share'])."""
    rows = (assessment.provenance or {}).get("faces") or []
    return {int(r["face"]): r.get("K_share") for r in rows if "face" in r}


def _sub_progress(progress, lo, hi):
    def sub(fraction, message=""):
        progress(lo + (hi - lo) * max(0.0, min(1.0, fraction)), message)
    return sub
