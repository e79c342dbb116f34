"""Edge topology of a triangle list from one sort of its side keys: undirected edges, how
many faces use each, the faces paired across every manifold edge, boundary and
non-manifold vertices, winding consistency (paper section 4.2, representation provenance).

Side j of face f runs from corner j to corner j+1 (mod 3). An undirected edge used by
exactly one face is a boundary edge, by more than two a non-manifold edge.

The sort is a counting sort: the sides are bucketed by their lower vertex and sorted by
the higher one within each bucket (scipy's compressed-sparse-row construction, linear in
the number of sides), so that the edges come out in the order of the keys
min(a, b) * n + max(a, b), as a full sort of the keys would give them.
"""
import importlib
import sys
import threading
from dataclasses import dataclass

import numpy as np

from ..core.threads import blocks, default_threads, run_blocks

#: Faces per block of the side pass.
BLOCK = 1 << 16


def _index_dtype(limit):
    return np.int32 if limit < np.iinfo(np.int32).max else np.int64


def import_sparse_in_background():
    """Import scipy.sparse and its graph algorithms on a background thread, for the edge
    table and the orientation that follow the reading of a file (their import runs while
    the reader and the weld work in numpy, which lets go of the interpreter)."""
    if "scipy.sparse.csgraph" not in sys.modules:
        threading.Thread(target=importlib.import_module, args=("scipy.sparse.csgraph",),
                         name="hullprod-import", daemon=True).start()


def sorted_pairs(rows, cols, n_rows, n_cols):
    """The integer pairs (rows[i], cols[i]) in lexicographic order.

    Returns (order (k,): the items sorted by (row, col), col (k,) of the sorted items,
    row_start (n_rows + 1,): where each row begins in that order). Items with equal pairs
    are adjacent, in no particular order among themselves. Linear: a counting sort by row
    (scipy's compressed-sparse-row construction), then a sort of each (short) row by col.
    """
    from scipy.sparse import coo_matrix
    k = len(rows)
    itype = _index_dtype(max(k, n_rows, n_cols) + 1)
    ij = (rows.astype(itype, copy=False), cols.astype(itype, copy=False))
    A = coo_matrix((np.arange(k, dtype=itype), ij), shape=(n_rows, n_cols))
    A.has_canonical_format = True      # keep repeated pairs apart: they are what we count
    C = A.tocsr()
    C.has_sorted_indices = False
    C.sort_indices()
    return C.data, C.indices, C.indptr


def side_keys(faces, n_vertices):
    """(m, 3) int64 key min(a, b) * n + max(a, b) of the undirected edge of each side."""
    lo, hi = side_ends(faces)
    return lo.astype(np.int64) * np.int64(n_vertices) + hi


def side_ends(faces):
    """(lo, hi): (m, 3) lower and higher vertex of the undirected edge of each side (int32
    where the vertex ids allow it), over blocks of faces on default_threads() threads."""
    F = np.asarray(faces)
    m = len(F)
    itype = _index_dtype(int(F.max()) + 1 if m else 0)
    lo = np.empty((m, 3), dtype=itype)
    hi = np.empty((m, 3), dtype=itype)

    def block(sl):
        f = F[sl].astype(itype, copy=False)
        nxt = np.roll(f, -1, axis=1)
        np.minimum(f, nxt, out=lo[sl])
        np.maximum(f, nxt, out=hi[sl])
    run_blocks(block, blocks(m, BLOCK), default_threads())
    return lo, hi


@dataclass
class EdgeTable:
    """Undirected edges of a triangle list.

    edges: (e, 2) int vertex pairs (lo, hi) in key order; count: (e,) faces using each
    edge; side_edge: (m, 3) edge id of each face side; pairs: (p, 2) faces sharing each
    manifold edge (count 2), in edge order, lower face first; pair_sides: (p, 2) the
    flat side ids (3 f + j) of those two faces.
    """

    edges: np.ndarray
    count: np.ndarray
    side_edge: np.ndarray = None
    pairs: np.ndarray = None
    pair_sides: np.ndarray = None

    @property
    def boundary(self):
        """(e,) bool, edges used by exactly one face."""
        return self.count == 1

    @property
    def nonmanifold(self):
        """(e,) bool, edges used by more than two faces."""
        return self.count > 2

    def vertex_flags(self, n_vertices):
        """(boundary, nonmanifold) (n,) bool: vertices on an edge used by exactly one face,
        and on an edge used by more than two faces (computed once, then shared: do not
        modify them)."""
        cached = getattr(self, "_flags", None)
        if cached is not None and len(cached[0]) == int(n_vertices):
            return cached
        out = []
        for sel in (self.count == 1, self.count > 2):
            flag = np.zeros(int(n_vertices), dtype=bool)
            flag[self.edges[sel].ravel()] = True
            out.append(flag)
        self._flags = tuple(out)
        return self._flags

    def side_count(self):
        """(m, 3) faces using the edge of each face side (computed once until flip_faces)."""
        cached = getattr(self, "_side_count", None)
        if cached is None:
            cached = self._side_count = self.count[self.side_edge]
        return cached

    def same_direction(self, faces):
        """(p,) bool per manifold edge: both faces run it the same way (their windings
        disagree; with consistent orientation one runs a -> b, the other b -> a).
        Remembered for these faces until flip_faces."""
        cached = getattr(self, "_same", None)
        if cached is not None and cached[0] is faces:
            return cached[1]
        F = np.asarray(faces)
        forward = np.empty(F.shape, dtype=bool)   # side runs lo -> hi
        np.less(F[:, 0], F[:, 1], out=forward[:, 0])
        np.less(F[:, 1], F[:, 2], out=forward[:, 1])
        np.less(F[:, 2], F[:, 0], out=forward[:, 2])
        forward = forward.ravel()
        same = forward[self.pair_sides[:, 0]] == forward[self.pair_sides[:, 1]]
        self._same = (faces, same)
        return same

    def flip_faces(self, flipped):
        """Update the table after the faces flipped ((m,) bool) were reversed [a, b, c] ->
        [c, b, a]: their sides 0 and 1 trade places, side 2 stays."""
        if not np.any(flipped):
            return
        self._same = self._side_count = None
        se = self.side_edge
        se[flipped] = se[flipped][:, [1, 0, 2]]
        swap = np.array([1, 0, 2])
        ps = self.pair_sides
        f = ps // 3
        hit = flipped[f]
        ps[hit] = 3 * f[hit] + swap[ps[hit] % 3]


def edge_table(faces, n_vertices):
    """Group the 3m sides into undirected edges with one counting sort (module docstring).
    Index arrays are int32 where the counts allow it."""
    F = np.asarray(faces)
    m = len(F)
    if m == 0:
        z = np.zeros((0, 2), np.int64)
        return EdgeTable(z, np.zeros(0, np.int64), np.zeros((0, 3), np.int64), z, z)
    lo, hi = side_ends(F)
    lo, hi = lo.reshape(-1), hi.reshape(-1)
    n = int(n_vertices)
    k = len(lo)
    itype = _index_dtype(max(k, n) + 1)
    order, col, row_start = sorted_pairs(lo, hi, n, n)
    del hi
    new = np.empty(k, dtype=bool)
    new[0] = True
    np.not_equal(col[1:], col[:-1], out=new[1:])
    new[row_start[row_start < k]] = True           # a new row is a new edge
    starts = np.flatnonzero(new).astype(itype, copy=False)
    count = np.diff(starts, append=itype(k))
    edges = np.stack([lo[order[starts]], col[starts]], axis=1)
    del lo, col
    side_edge = np.empty(k, dtype=itype)
    side_edge[order] = np.cumsum(new, dtype=itype) - 1
    del new
    two = starts[count == 2]
    s1, s2 = order[two], order[two + 1]
    pair_sides = np.empty((len(two), 2), dtype=itype)
    np.minimum(s1, s2, out=pair_sides[:, 0])
    np.maximum(s1, s2, out=pair_sides[:, 1])
    return EdgeTable(edges, count, side_edge.reshape(-1, 3), pair_sides // 3, pair_sides)


def vertex_flags(faces, n_vertices):
    """Boundary and non-manifold vertex flags from the edge table of faces.

    Returns (boundary (n,) bool: on an edge used by exactly one face,
    nonmanifold (n,) bool: on an edge used by more than two faces).
    """
    return edge_table(faces, n_vertices).vertex_flags(n_vertices)


def face_pairs(faces, table):
    """Faces sharing a manifold interior edge: (p, 2) face ids and (p,) bool same_direction
    (see EdgeTable.same_direction). table is the EdgeTable of faces."""
    return table.pairs, table.same_direction(faces)


def face_neighbours(table, m):
    """(m, 3) face across each side over a manifold edge, -1 where the edge is a boundary
    or non-manifold edge."""
    ps = table.pair_sides
    nb = np.full(3 * m, -1, dtype=ps.dtype)
    nb[ps[:, 0]] = ps[:, 1] // 3
    nb[ps[:, 1]] = ps[:, 0] // 3
    return nb.reshape(-1, 3)
