"""Edge topology of a triangle list: undirected edges, how many faces use each, boundary
and non-manifold vertices, winding consistency (paper section 4.2, representation
provenance).

Side j of face f runs from corner j to corner j+1 (mod 3). An undirected edge used by
exactly one face is a boundary edge, by more than two a non-manifold edge.
"""
from dataclasses import dataclass

import numpy as np


def side_keys(faces, n_vertices):
    """(m, 3) int64 key min(a, b) * n + max(a, b) of the undirected edge of each side."""
    F = np.asarray(faces, dtype=np.int64)
    n = np.int64(n_vertices)
    keys = np.empty(F.shape, dtype=np.int64)
    for j in range(3):  # three columns, not a loop over faces
        a, b = F[:, j], F[:, (j + 1) % 3]
        lo = np.minimum(a, b)
        keys[:, j] = lo * n + (a + b - lo)
    return keys


@dataclass
class EdgeTable:
    """Undirected edges of a triangle list.

    edges: (e, 2) int64 vertex pairs (lo, hi); count: (e,) faces using each edge;
    side_edge: (m, 3) edge id of each face side (or None when not requested).
    """

    edges: np.ndarray
    count: np.ndarray
    side_edge: object = None

    @property
    def boundary(self):
        """(e,) bool, edges used by exactly one face."""
        return self.count == 1

    @property
    def nonmanifold(self):
        """(e,) bool, edges used by more than two faces."""
        return self.count > 2


def edge_table(faces, n_vertices, with_sides=True):
    """Sort the 3m side keys once and group them into undirected edges."""
    keys = side_keys(faces, n_vertices).ravel()
    n = np.int64(n_vertices)
    if len(keys) == 0:
        return EdgeTable(np.zeros((0, 2), np.int64), np.zeros(0, np.int64),
                         np.zeros((0, 3), np.int64) if with_sides else None)
    if with_sides:
        order = np.argsort(keys, kind="stable")
        s = keys[order]
    else:
        s = np.sort(keys, kind="stable")
    new = np.empty(len(s), dtype=bool)
    new[0] = True
    np.not_equal(s[1:], s[:-1], out=new[1:])
    starts = np.flatnonzero(new)
    count = np.diff(np.append(starts, len(s)))
    uk = s[starts]
    edges = np.stack([uk // n, uk % n], axis=1)
    side_edge = None
    if with_sides:
        eid = np.cumsum(new) - 1
        side_edge = np.empty(len(s), dtype=np.int64)
        side_edge[order] = eid
        side_edge = side_edge.reshape(-1, 3)
    return EdgeTable(edges, count, side_edge)


def vertex_flags(faces, n_vertices):
    """Boundary and non-manifold vertex flags from one sort of the side keys.

    Returns (boundary (n,) bool: on an edge used by exactly one face,
    nonmanifold (n,) bool: on an edge used by more than two faces).
    """
    n = int(n_vertices)
    boundary = np.zeros(n, dtype=bool)
    nonmanifold = np.zeros(n, dtype=bool)
    s = np.sort(side_keys(faces, n).ravel(), kind="stable")
    if len(s) == 0:
        return boundary, nonmanifold
    same = s[1:] == s[:-1]                    # same[i]: s[i] and s[i+1] are one edge
    alone = np.ones(len(s), dtype=bool)       # key equal to neither neighbour: used once
    alone[1:] &= ~same
    alone[:-1] &= ~same
    for keys, flag in ((s[alone], boundary), (s[:-2][same[1:] & same[:-1]], nonmanifold)):
        lo = keys // n
        flag[lo] = True
        flag[keys - lo * n] = True
    return boundary, nonmanifold


def face_pairs(faces, table):
    """Faces sharing a manifold interior edge: (p, 2) face ids and (p,) bool same_direction.

    same_direction is True where both faces run the shared edge the same way, i.e. their
    windings disagree (with consistent orientation one runs a -> b, the other b -> a).
    table is the EdgeTable of faces (with sides).
    """
    F = np.asarray(faces, dtype=np.int64)
    side = table.side_edge.ravel()
    forward = (F < np.roll(F, -1, axis=1)).ravel()  # side runs lo -> hi
    sides = np.flatnonzero(table.count[side] == 2)
    sides = sides[np.argsort(side[sides], kind="stable")].reshape(-1, 2)
    return sides // 3, forward[sides[:, 0]] == forward[sides[:, 1]]
