"""Slow, direct reference implementations of the mesh preparation steps, for the tests that
check the fast paths against them: numpy's exact unique and argsort instead of hashing
and counting sorts, the double-cover orientation for every mesh, einsum and cross
products over (m, 3, 3) corner arrays, np.percentile on the whole array."""
import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from hullprod_wb.mesh.curvature import DEGENERATE_RTOL


def weld(V, F=None):
    """(vertices, faces, merged) by np.unique of the float64 rows, first occurrence order."""
    Vc = np.asarray(V, dtype=np.float64) + 0.0
    F = np.arange(len(Vc)).reshape(-1, 3) if F is None else F
    _, first, inverse = np.unique(Vc, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")
    rank = np.empty(len(first), dtype=np.int64)
    rank[order] = np.arange(len(first))
    return Vc[first[order]], rank[inverse.ravel()][F], len(Vc) - len(first)


def edges(F, n):
    """(edges (e, 2), count (e,), side_edge (m, 3), pairs (p, 2), same (p,)) by argsort."""
    F = np.asarray(F, dtype=np.int64)
    a, b = F, np.roll(F, -1, axis=1)
    keys = (np.minimum(a, b) * n + np.maximum(a, b)).ravel()
    order = np.argsort(keys, kind="stable")
    uk, inverse, count = np.unique(keys, return_inverse=True, return_counts=True)
    E = np.stack([uk // n, uk % n], axis=1)
    side_edge = inverse.reshape(-1, 3)
    sides = order[count[inverse[order]] == 2].reshape(-1, 2)
    forward = (a < b).ravel()
    return E, count, side_edge, sides // 3, forward[sides[:, 0]] == forward[sides[:, 1]]


def duplicates(F):
    """m - the number of distinct sorted vertex triples."""
    return len(F) - len(np.unique(np.sort(F, axis=1), axis=0))


def orient(V, F, count, side_edge, pairs, same):
    """The double-cover orientation for every mesh: (faces, winding flips, inverted faces,
    non-orientable faces, pieces, closed pieces)."""
    m = len(F)
    a, b = pairs[:, 0], pairs[:, 1]
    rows = np.concatenate([a, a + m])
    cols = np.concatenate([np.where(same, b + m, b), np.where(same, b, b + m)])
    g = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(2 * m, 2 * m))
    _, label = connected_components(g, directed=False)
    keep, alt = label[:m], label[m:]
    nkeep = np.bincount(keep, minlength=label.max() + 1)
    flip = (nkeep[alt] > nkeep[keep]) | ((nkeep[alt] == nkeep[keep]) & (alt < keep))
    bad = keep == alt
    out = F.copy()
    out[flip] = out[flip][:, ::-1]
    piece = np.unique(np.minimum(keep, alt), return_inverse=True)[1]
    npieces = piece.max() + 1
    is_open = np.bincount(piece, weights=(count[side_edge] != 2).any(axis=1) | bad, minlength=npieces) > 0
    P = V[out]
    vol = np.bincount(piece, weights=np.einsum("ij,ij->i", P[:, 0], np.cross(P[:, 1], P[:, 2])), minlength=npieces)
    inv = (~is_open & (vol < 0))[piece]
    out[inv] = out[inv][:, ::-1]
    return out, int(flip.sum()), int(inv.sum()), int(bad.sum()), int(npieces), int((~is_open).sum())


def triangle_measures(V, F):
    """(area, q, smallest angle, largest angle, degenerate) over (m, 3, 3) corner arrays."""
    P = V[F]
    e = P[:, [1, 2, 0]] - P
    l2 = np.einsum("ijk,ijk->ij", e, e)
    dblA = np.linalg.norm(np.cross(e[:, 0], e[:, 1]), axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        q = 2.0 * np.sqrt(3.0) * dblA / l2.sum(axis=1)
    ang = np.degrees(np.arctan2(dblA[:, None], -np.einsum("ijk,ijk->ij", e, e[:, [2, 0, 1]])))
    repeated = (F[:, 0] == F[:, 1]) | (F[:, 1] == F[:, 2]) | (F[:, 2] == F[:, 0])
    degenerate = repeated | ~(dblA > DEGENERATE_RTOL * l2.max(axis=1))
    return 0.5 * dblA, q, ang.min(axis=1), ang.max(axis=1), degenerate


def normal_angles(V, F, pairs):
    """Degrees between the unit normals (p1 - p0) x (p2 - p0) of each face pair."""
    P = V[F]
    N = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
    N /= np.linalg.norm(N, axis=1)[:, None]
    a, b = N[pairs[:, 0]], N[pairs[:, 1]]
    return np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b)))


def summary(x):
    """min, p01, p05, median, p95, p99, max, mean by np.percentile on the finite values."""
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    p = np.percentile(x, (1, 5, 50, 95, 99))
    keys = ("min", "p01", "p05", "median", "p95", "p99", "max", "mean")
    return dict(zip(keys, map(float, (x.min(), *p, x.max(), x.mean()))))
