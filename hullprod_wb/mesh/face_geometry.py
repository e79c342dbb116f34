"""Per-triangle measures computed once for loading and quality (paper section 4.2,
representation provenance): squared side lengths, doubled area, the degenerate test,
shape quality, smallest and largest angle, unit normals and the angle between the normals
of the faces paired across manifold edges.

Side j of face f runs from corner j to corner j+1: e_j = p_{j+1} - p_j. Doubled area
2A = |e_0 x e_1|; shape quality q = 4 sqrt(3) A / (l_0^2 + l_1^2 + l_2^2) (1 for an
equilateral triangle, 0 for a sliver); the angle at corner j is atan2(2A, -e_j . e_{j-1}).
A triangle is degenerate when it repeats a vertex or 2A <= DEGENERATE_RTOL * max_j l_j^2.
Everything runs over blocks of faces in (3, b) coordinate rows, which keeps the
temporaries in cache.
"""
from dataclasses import dataclass

import numpy as np

from ..core.threads import blocks, default_threads, run_blocks
from .curvature import DEGENERATE_RTOL

#: Faces per block.
BLOCK = 1 << 16


def _each_block(fn, m):
    """fn(slice) for every block of m items, on default_threads() threads (the blocks
    write disjoint slices)."""
    run_blocks(fn, blocks(m, BLOCK), default_threads())


def coordinate_rows(V):
    """(3, n) contiguous float64 coordinate rows of the vertices V (n, 3): the layout every
    block pass reads. The loading makes them once per mesh (PreparedMesh.rows) and hands
    them on as rows= to the passes, which otherwise make their own."""
    return np.ascontiguousarray(np.asarray(V, dtype=float).T)


def _corners(Vt, F, sl):
    return [np.take(Vt, F[sl, j], axis=1) for j in range(3)]


def _norm2(a):
    """Squared length of (3, b) rows, summed as np.linalg.norm sums them."""
    return a[0] * a[0] + a[1] * a[1] + a[2] * a[2]


def _dot(a, b):
    """Row-wise dot product of (3, b) rows, summed in the order of np.einsum's
    'ij,ij->i' over three components ((x + z) + y), so that the values are the same."""
    return (a[0] * b[0] + a[2] * b[2]) + a[1] * b[1]


def _cross(a, b):
    return np.stack([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


@dataclass
class FaceMeasures:
    """(m,) float arrays: area, shape quality q, smallest and largest angle in degrees;
    degenerate (m,) bool (see the module docstring)."""

    area: np.ndarray
    quality: np.ndarray
    min_angle: np.ndarray
    max_angle: np.ndarray
    degenerate: np.ndarray

    def take(self, index):
        """The measures of the faces index (bool mask or ids)."""
        return FaceMeasures(self.area[index], self.quality[index], self.min_angle[index],
                            self.max_angle[index], self.degenerate[index])

    def put(self, index, other):
        """Overwrite the faces index with the measures other."""
        for name in ("area", "quality", "min_angle", "max_angle", "degenerate"):
            getattr(self, name)[index] = getattr(other, name)


def face_measures(V, F, rows=None):
    """FaceMeasures of the faces F (m, 3) of the vertices V (n, 3) (rows: their
    coordinate_rows when at hand)."""
    m = len(F)
    Vt = coordinate_rows(V) if rows is None else rows
    out = FaceMeasures(np.empty(m), np.empty(m), np.empty(m), np.empty(m), np.empty(m, dtype=bool))
    sqrt3x2 = 2.0 * np.sqrt(3.0)

    def block(sl):
        p = _corners(Vt, F, sl)
        e = [p[1] - p[0], p[2] - p[1], p[0] - p[2]]
        l2 = [_dot(ej, ej) for ej in e]
        dblA = np.sqrt(_norm2(_cross(e[0], e[1])))
        f = F[sl]
        repeated = (f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 2] == f[:, 0])
        longest = np.maximum(np.maximum(l2[0], l2[1]), l2[2])
        out.degenerate[sl] = repeated | ~(dblA > DEGENERATE_RTOL * longest)
        out.area[sl] = 0.5 * dblA
        with np.errstate(invalid="ignore", divide="ignore"):
            out.quality[sl] = sqrt3x2 * dblA / (l2[0] + l2[1] + l2[2])
        ang = [np.degrees(np.arctan2(dblA, -_dot(e[j], e[j - 1]))) for j in range(3)]
        out.min_angle[sl] = np.minimum(np.minimum(ang[0], ang[1]), ang[2])
        out.max_angle[sl] = np.maximum(np.maximum(ang[0], ang[1]), ang[2])
    _each_block(block, m)
    return out


def vertex_areas(F, area, n):
    """(n,) barycentric node areas: A_t / 3 summed over the triangles t at each node
    (eq:vertex_area), corner by corner in face order."""
    return np.bincount(np.ravel(F), weights=np.repeat(area / 3.0, 3), minlength=n)


def unit_normals(V, F, rows=None):
    """(3, m) unit normals (p1 - p0) x (p2 - p0) / |...| of the faces (NaN where zero);
    rows: V's coordinate_rows when at hand."""
    m = len(F)
    Vt = coordinate_rows(V) if rows is None else rows
    N = np.empty((3, m))

    def block(sl):
        p = _corners(Vt, F, sl)
        n = _cross(p[1] - p[0], p[2] - p[0])
        with np.errstate(invalid="ignore", divide="ignore"):
            N[:, sl] = n / np.sqrt(_norm2(n))
    _each_block(block, m)
    return N


def normal_angles(N, pairs):
    """Angle in degrees between the unit normals N (3, m) of each face pair (p, 2):
    atan2(|a x b|, a . b)."""
    out = np.empty(len(pairs))

    def block(sl):
        a = np.take(N, pairs[sl, 0], axis=1)
        b = np.take(N, pairs[sl, 1], axis=1)
        c = _cross(a, b)
        out[sl] = np.degrees(np.arctan2(np.sqrt(_norm2(c)), _dot(a, b)))
    _each_block(block, len(pairs))
    return out


def edge_lengths(V, edges, rows=None):
    """(e,) lengths |V[b] - V[a]| of the edges (e, 2), over blocks (no (e, 3) temporaries);
    rows: V's coordinate_rows when at hand."""
    Vt = coordinate_rows(V) if rows is None else rows
    out = np.empty(len(edges))

    def block(sl):
        d = np.take(Vt, edges[sl, 1], axis=1) - np.take(Vt, edges[sl, 0], axis=1)
        out[sl] = np.sqrt(_norm2(d))
    _each_block(block, len(edges))
    return out
