"""Structured same-face grids and the mesh operators of eq:sameface_error (paper section 5.2):
grid lines with creases on lines, the two diagonal patterns, the two-ring strict interior,
the consistent P1 mass matrix and the relative L2 error. See :mod:`.sameface`."""
import numpy as np
from scipy import sparse

from ..core.errors import InputError

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
