"""Generated triangle meshes of the analytical controls (paper section 5.1).

Every generator returns ``(vertices (n, 3) float, faces (m, 3) int64)`` with faces
oriented so that the normal is X_u x X_v of the stated parametrisation. Structured grids
split each quad (a, b, c, d) = ((i, j), (i+1, j), (i+1, j+1), (i, j+1)) along one of its two
diagonals, chosen by ``pattern``:

- 'consistent': every quad split along b-d,
- 'alternating': b-d and a-c in a checkerboard ((i + j) even / odd),
- 'random': a seeded random choice per quad (numpy default_rng(seed)).

so that sensitivity to connectivity can be separated from changes of shape.
"""
import numpy as np

from ..core.errors import InputError
from .builtin import WIGLEY_B, WIGLEY_L, WIGLEY_T

PATTERNS = ("consistent", "alternating", "random")


def diagonal_choice(shape, pattern="consistent", seed=0):
    """(shape) bool, True where a quad is split along a-c instead of b-d."""
    if pattern == "consistent":
        return np.zeros(shape, dtype=bool)
    if pattern == "alternating":
        i, j = np.indices(shape)
        return (i + j) % 2 == 1
    if pattern == "random":
        return np.random.default_rng(seed).integers(0, 2, size=shape).astype(bool)
    raise InputError("unknown diagonal pattern %r (use one of %s)" % (pattern, ", ".join(PATTERNS)))


def grid_faces(nu, nv, pattern="consistent", seed=0, periodic_u=False, periodic_v=False):
    """Triangles of an (nu, nv) vertex grid with vertex id i * nv + j.

    Quads run over i < nu - 1 (or nu when periodic in u, wrapping to 0) and likewise j.
    Returns (2 * quads, 3) int64 oriented as (u, v) counter-clockwise.
    """
    qu = nu if periodic_u else nu - 1
    qv = nv if periodic_v else nv - 1
    if qu < 1 or qv < 1:
        raise InputError("a grid needs at least 2 x 2 vertices, got %d x %d" % (nu, nv))
    i, j = np.meshgrid(np.arange(qu), np.arange(qv), indexing="ij")
    i1 = (i + 1) % nu
    j1 = (j + 1) % nv
    a = i * nv + j
    b = i1 * nv + j
    c = i1 * nv + j1
    d = i * nv + j1
    flip = diagonal_choice((qu, qv), pattern, seed)
    t1 = np.where(flip[..., None], np.stack([a, b, c], -1), np.stack([a, b, d], -1))
    t2 = np.where(flip[..., None], np.stack([a, c, d], -1), np.stack([b, c, d], -1))
    return np.stack([t1, t2], axis=2).reshape(-1, 3).astype(np.int64)


def _grid_vertices(X, Y, Z):
    return np.stack([np.ravel(X), np.ravel(Y), np.ravel(Z)], axis=1).astype(float)


def plane_mesh(n=16, size=2.0, pattern="consistent", seed=0):
    """Square z = 0, [-size/2, size/2]^2 with n x n quads (H = K = 0)."""
    s = np.linspace(-0.5 * size, 0.5 * size, n + 1)
    X, Y = np.meshgrid(s, s, indexing="ij")
    return _grid_vertices(X, Y, np.zeros_like(X)), grid_faces(n + 1, n + 1, pattern, seed)


def saddle_mesh(n=16, pattern="consistent", seed=0):
    """z = (x^2 - y^2) / 4 on [-1, 1]^2 with n x n quads.

    K = -(1/4) / (1 + (x^2 + y^2)/4)^2 < 0 everywhere, normal (-z_x, -z_y, 1) upward.
    """
    s = np.linspace(-1.0, 1.0, n + 1)
    X, Y = np.meshgrid(s, s, indexing="ij")
    return _grid_vertices(X, Y, 0.25 * (X ** 2 - Y ** 2)), grid_faces(n + 1, n + 1, pattern, seed)


def cylinder_mesh(n_theta=32, n_z=16, radius=1.0, height=2.0, pattern="consistent", seed=0):
    """Open cylinder x^2 + y^2 = radius^2, 0 <= z <= height, periodic in theta.

    (theta, z) grid of n_theta x n_z quads; outward normal; K = 0, H = 1/(2 radius).
    """
    th = np.linspace(0.0, 2.0 * np.pi, n_theta, endpoint=False)
    z = np.linspace(0.0, height, n_z + 1)
    T, Zz = np.meshgrid(th, z, indexing="ij")
    V = _grid_vertices(radius * np.cos(T), radius * np.sin(T), Zz)
    return V, grid_faces(n_theta, n_z + 1, pattern, seed, periodic_u=True)


def torus_mesh(n=16, R=3.0, r=1.0, pattern="consistent", seed=0, n_u=None):
    """Closed torus ((R + r cos v) cos u, (R + r cos v) sin u, r sin v), periodic grid.

    n quads around the tube (v) and n_u (default round(n R / r)) around the axis (u), so
    that the quads are near square on the outer equator. Outward normal;
    K = cos v / (r (R + r cos v)); with L_ref = 8 (R = 3, r = 1), I_D = 128/(3 pi).
    """
    if n_u is None:
        n_u = max(3, int(round(n * R / r)))
    u = np.linspace(0.0, 2.0 * np.pi, n_u, endpoint=False)
    v = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    U, Vv = np.meshgrid(u, v, indexing="ij")
    rho = R + r * np.cos(Vv)
    V = _grid_vertices(rho * np.cos(U), rho * np.sin(U), r * np.sin(Vv))
    return V, grid_faces(n_u, n, pattern, seed, periodic_u=True, periodic_v=True)


def half_wigley_mesh(nx, nz, pattern="consistent", seed=0, grading=0.0, L=WIGLEY_L, B=WIGLEY_B,
                     T=WIGLEY_T):
    """Half-Wigley hull y = B/2 (1 - (2x/L)^2)(1 - (z/T)^2), |x| <= L/2, -T <= z <= 0.

    nx x nz quads on an (x, z) grid, open on all four sides, normal towards +y (outward
    for this starboard half). grading in [0, 1) clusters the x stations toward the ends:
    x = L/2 [(1 - g) s + g sin(pi s / 2)], s uniform in [-1, 1] (monotone for g < 1).
    """
    if not 0.0 <= grading < 1.0:
        raise InputError("grading must lie in [0, 1), got %r" % (grading,))
    s = np.linspace(-1.0, 1.0, nx + 1)
    x = 0.5 * L * ((1.0 - grading) * s + grading * np.sin(0.5 * np.pi * s))
    z = np.linspace(0.0, -T, nz + 1)  # z decreasing makes (x, z) x-then-z counter-clockwise seen from +y
    X, Zz = np.meshgrid(x, z, indexing="ij")
    Y = 0.5 * B * (1.0 - (2.0 * X / L) ** 2) * (1.0 - (Zz / T) ** 2)
    return _grid_vertices(X, Y, Zz), grid_faces(nx + 1, nz + 1, pattern, seed)


def _icosahedron():
    """12 unit vertices and 20 outward-oriented faces of the regular icosahedron."""
    from scipy.spatial import ConvexHull
    p = (1.0 + 5.0 ** 0.5) / 2.0
    V = np.array([[0, s1, s2 * p] for s1 in (-1, 1) for s2 in (-1, 1)], float)
    V = np.concatenate([V, np.roll(V, 1, axis=1), np.roll(V, 2, axis=1)])
    V /= np.linalg.norm(V, axis=1)[:, None]
    F = ConvexHull(V).simplices.astype(np.int64)
    nrm = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    inward = np.einsum("ij,ij->i", nrm, V[F].mean(axis=1)) < 0
    F[inward] = F[inward][:, ::-1]
    return V, F


def icosphere_mesh(frequency=8, pattern="consistent", seed=0, radius=1.0):
    """Geodesic sphere: each icosahedron face split into frequency^2 triangles, projected.

    Vertices lie on the sphere of the given radius (10 f^2 + 2 of them). Inside a face the
    lattice point (i, j) is A + (B - A) i/f + (C - A) j/f; the up/down triangle pairs form
    rhombi (i, j), (i+1, j), (i+1, j+1), (i, j+1) whose diagonal is chosen by pattern
    (consistent: the short diagonal). Outward normal; H = 1/radius, K = 1/radius^2.
    """
    f = int(frequency)
    if f < 1:
        raise InputError("icosphere frequency must be >= 1, got %r" % (frequency,))
    V0, F0 = _icosahedron()
    ii, jj = [a.ravel() for a in np.meshgrid(np.arange(f + 1), np.arange(f + 1), indexing="ij")]
    keep = ii + jj <= f
    ii, jj = ii[keep], jj[keep]
    lid = -np.ones((f + 1, f + 1), dtype=np.int64)
    lid[ii, jj] = np.arange(len(ii))
    npf = len(ii)
    # Integer barycentric weights over the 12 icosahedron vertices: shared points get equal rows.
    W = np.zeros((len(F0) * npf, 12), dtype=np.int64)
    rows = np.arange(len(F0) * npf)
    for corner, w in enumerate((f - ii - jj, ii, jj)):
        np.add.at(W, (rows, np.repeat(F0[:, corner], npf)), np.tile(w, len(F0)))
    Wu, inv = np.unique(W, axis=0, return_inverse=True)
    P = Wu @ V0
    P *= radius / np.linalg.norm(P, axis=1)[:, None]
    # Lattice triangles of one face, then all faces.
    qi, qj = [a.ravel() for a in np.meshgrid(np.arange(f), np.arange(f), indexing="ij")]
    up = qi + qj <= f - 1
    ui, uj = qi[up], qj[up]
    rh = ui + uj <= f - 2          # up triangles with a down partner form a rhombus
    a, b, d = lid[ui, uj], lid[ui + 1, uj], lid[ui, uj + 1]
    c = np.where(rh, lid[np.minimum(ui + 1, f), np.minimum(uj + 1, f)], -1)
    flip = np.zeros(len(ui), dtype=bool)
    if rh.any():
        flip[rh] = diagonal_choice((int(rh.sum()),), pattern, seed) if pattern != "alternating" \
            else ((ui[rh] + uj[rh]) % 2 == 1)
    lone = ~rh
    tri = np.concatenate([
        np.stack([a[lone], b[lone], d[lone]], 1),
        np.stack([a[rh & ~flip], b[rh & ~flip], d[rh & ~flip]], 1),
        np.stack([b[rh & ~flip], c[rh & ~flip], d[rh & ~flip]], 1),
        np.stack([a[flip], b[flip], c[flip]], 1),
        np.stack([a[flip], c[flip], d[flip]], 1),
    ])
    faces = (np.arange(len(F0))[:, None, None] * npf + tri[None]).reshape(-1, 3)
    return P, inv.reshape(-1)[faces].astype(np.int64)


#: name -> generator, for tests and benchmarks.
GENERATORS = {
    "plane": plane_mesh,
    "icosphere": icosphere_mesh,
    "cylinder": cylinder_mesh,
    "saddle": saddle_mesh,
    "torus": torus_mesh,
    "half_wigley": half_wigley_mesh,
}
