"""Triangle-mesh input: STL (ASCII and binary), OBJ and PLY files, arrays, trimesh and
FreeCAD meshes, checked and prepared the same way (paper section 4.2).

Preparation never modifies the caller's object and applies no smoothing or remeshing:

1. non-finite coordinates, an empty face list or bad indices raise InputError;
2. exactly equal vertices are welded (STL stores every triangle with its own corners);
3. degenerate triangles (repeated vertex, or 2A <= DEGENERATE_RTOL * longest edge^2) are
   removed and counted; if nothing remains, InputError;
4. vertices no triangle uses are dropped and counted;
5. non-manifold edges (used by more than two triangles) and duplicated triangles are
   counted, not repaired (InputError only if every edge is non-manifold);
6. the winding is made consistent across manifold edges (the orientation of the larger
   part of each connected piece is kept) and closed pieces are turned outward (positive
   enclosed volume); the number of flipped triangles is recorded.

Welding, the degenerate test and the topology each take one pass: the vertices are grouped
by a hash table of their stored bits (:mod:`.weld`), the sides by their edge keys with one
linear counting sort (:mod:`.topology`, built on a second thread while the triangle
measures of :mod:`.face_geometry` are taken), and the edge table, the measures and the
vertex flags found here are handed on to the quality record and the curvature. With
with_quality, the quality record (:mod:`.quality`) is measured on a second thread while
the duplicates are counted and the winding made consistent; it stands when no face is
reversed and is measured again when one is. The record of all this is the PreparedMesh's
info, ``mesh.metadata['hullprod']`` of the trimesh.Trimesh that :func:`load_mesh` returns.
"""
import os
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from ..core.errors import InputError
from ..core.inputs import checked_path, sha256_file
from .curvature import check_arrays, check_faces, check_finite
from .face_geometry import coordinate_rows, face_measures
from .quality import finished_record, measured_record
from .readers import read_mesh_file, require_trimesh
from .topology import edge_table, face_neighbours, import_sparse_in_background
from .weld import unique_rows, weld_exact


def load_mesh(path):
    """Read an STL (ASCII or binary), OBJ or PLY file and prepare it (module docstring).

    Returns a trimesh.Trimesh whose metadata['hullprod'] records the preparation.
    """
    return load_prepared(path).to_trimesh()


def load_prepared(path, progress=None, with_quality=False):
    """Read and prepare a mesh file: a PreparedMesh (see :func:`prepare`)."""
    path, fmt, _ = checked_path(path, "mesh")
    import_sparse_in_background()
    progress = progress or (lambda fraction, message: None)
    progress(0.0, "reading %s" % os.path.basename(path))
    raw = read_mesh_file(path, fmt)
    source = {"kind": "file", "path": path, "format": fmt}
    return prepare(raw.vertices, raw.faces, source, progress, with_quality)


def mesh_from_arrays(vertices, faces, name="arrays"):
    """Prepare a mesh from (n, 3) float vertices and (m, 3) int faces (copied, not modified)."""
    return prepared_from_arrays(vertices, faces, name).to_trimesh()


def prepared_from_arrays(vertices, faces, name="arrays", with_quality=False):
    """mesh_from_arrays as a PreparedMesh."""
    V, F = check_arrays(np.array(vertices, dtype=float, copy=True), np.array(faces, copy=True))
    return prepare(V, F, {"kind": "arrays", "name": name}, with_quality=with_quality)


def mesh_from_trimesh(mesh):
    """Prepare a copy of a trimesh.Trimesh (the caller's object is not modified)."""
    return prepared_from_trimesh(mesh).to_trimesh()


def prepared_from_trimesh(mesh, with_quality=False):
    """mesh_from_trimesh as a PreparedMesh."""
    source = {"kind": "trimesh"}
    if getattr(mesh, "metadata", None) and "file_name" in mesh.metadata:
        source["name"] = mesh.metadata["file_name"]
    return prepare(np.array(mesh.vertices, dtype=float), np.array(mesh.faces), source,
                   with_quality=with_quality)


def mesh_from_freecad(obj):
    """Prepare a FreeCAD Mesh.Mesh, or a document object with a Mesh property.

    The points come from Mesh.Topology, which has the object's placement applied.
    """
    return prepared_from_freecad(obj).to_trimesh()


def prepared_from_freecad(obj, with_quality=False):
    """mesh_from_freecad as a PreparedMesh."""
    from ..freecad_env import import_freecad
    import_freecad()
    import Mesh
    source = {"kind": "FreeCAD"}
    mesh = obj
    if not isinstance(obj, Mesh.Mesh):
        mesh = getattr(obj, "Mesh", None)
        source["object"] = getattr(obj, "Name", None)
        source["label"] = getattr(obj, "Label", None)
    if not isinstance(mesh, Mesh.Mesh):
        raise InputError("expected a FreeCAD Mesh.Mesh or an object with a Mesh, got %s" % type(obj).__name__)
    points, facets = mesh.Topology
    if len(facets) == 0:
        raise InputError("the FreeCAD mesh has no facets")
    V = np.array(points, dtype=float).reshape(-1, 3)
    F = np.array(facets, dtype=np.int64).reshape(-1, 3)
    return prepare(V, F, source, with_quality=with_quality)


def degenerate_faces(V, F):
    """(m,) bool: triangles with a repeated vertex or 2A <= DEGENERATE_RTOL * (longest edge)^2."""
    return face_measures(V, F).degenerate


def _face_components(m, pairs):
    """(labels (m,), count): pieces of faces joined across the manifold edges pairs (p, 2),
    numbered in the order of their lowest face."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    g = coo_matrix((np.ones(len(pairs), dtype=np.int8), (pairs[:, 0], pairs[:, 1])), shape=(m, m))
    count, labels = connected_components(g, directed=False)
    return labels, int(count)


def _signed_volumes(Vt, F):
    """(m,) p0 . (p1 x p2) / 6 of every face (the tetrahedron with the origin); Vt: the
    vertices' coordinate rows (3, n)."""
    out = np.empty(len(F))
    step = 1 << 15
    for a in range(0, len(F), step):
        p0, p1, p2 = (np.take(Vt, F[a:a + step, j], axis=1) for j in range(3))
        out[a:a + step] = (p0[0] * (p1[1] * p2[2] - p1[2] * p2[1]) + p0[1] * (p1[2] * p2[0] - p1[0] * p2[2])
                           + p0[2] * (p1[0] * p2[1] - p1[1] * p2[0])) / 6.0
    return out


def orient_faces(V, F, table, rows=None):
    """Consistent winding across manifold edges; closed pieces turned outward.

    Each triangle f gets two nodes, f (kept) and f + m (flipped); an edge whose two
    triangles agree joins f-g and f+m-g+m, one where they disagree joins f-(g+m) and
    (f+m)-g. In a piece that can be oriented the two nodes of a triangle fall into two
    different components; the component holding more kept nodes wins. (Where every edge
    agrees already, the components are the pieces of the face graph and nothing flips.)
    A piece with no boundary and no non-manifold edge is then flipped as a whole if its
    signed volume sum(p0 . (p1 x p2))/6 is negative. rows: V's coordinate_rows when at
    hand. Returns (faces, info dict, (m,) bool reversed faces); the table is left as it is
    (EdgeTable.flip_faces updates it).
    """
    m = len(F)
    pairs, same = table.pairs, table.same_direction(F)
    if not same.any():
        piece, npieces = _face_components(m, pairs)
        flip = np.zeros(m, dtype=bool)
        non_orientable = flip
    else:
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import connected_components
        a, b = pairs[:, 0], pairs[:, 1]
        heads = np.concatenate([a, a + m])
        tails = np.concatenate([np.where(same, b + m, b), np.where(same, b, b + m)])
        graph = coo_matrix((np.ones(len(heads), dtype=np.int8), (heads, tails)), shape=(2 * m, 2 * m))
        _, label = connected_components(graph, directed=False)
        keep, alt = label[:m], label[m:]
        nkeep = np.bincount(keep, minlength=label.max() + 1)
        flip = (nkeep[alt] > nkeep[keep]) | ((nkeep[alt] == nkeep[keep]) & (alt < keep))
        non_orientable = keep == alt
        # pieces: the unordered pair of double-cover components
        piece = np.unique(np.minimum(keep, alt), return_inverse=True)[1]
        npieces = int(piece.max()) + 1 if m else 0
    out = F
    if flip.any():
        out = F.copy()
        out[flip] = out[flip][:, ::-1]
    sc = table.side_count()
    open_face = (sc[:, 0] != 2) | (sc[:, 1] != 2) | (sc[:, 2] != 2) | non_orientable
    if npieces == 1:
        piece_open = np.array([open_face.any()])
    else:
        piece_open = np.bincount(piece, weights=open_face, minlength=npieces) > 0
    del open_face
    Vt = coordinate_rows(V) if rows is None else rows
    piece_vol = np.bincount(piece, weights=_signed_volumes(Vt, out), minlength=npieces)
    invert_piece = ~piece_open & (piece_vol < 0)
    inv = invert_piece[piece]
    if inv.any():
        out = F.copy() if out is F else out
        out[inv] = out[inv][:, ::-1]
    reversed_faces = flip ^ inv
    info = {
        "winding_flipped_faces": int(np.count_nonzero(flip)),
        "inverted_closed_pieces": int(np.count_nonzero(invert_piece)),
        "inverted_faces": int(np.count_nonzero(inv)),
        "non_orientable_faces": int(np.count_nonzero(non_orientable)),
        "pieces": npieces,
        "closed_pieces": int(np.count_nonzero(~piece_open)),
    }
    info["orientation_changed"] = bool(np.any(reversed_faces))
    return out, info, reversed_faces


def duplicate_face_count(F, table):
    """Triangles beyond the first on the same three vertices (m - distinct vertex sets).

    Two triangles on the same vertices share all three edges. Where those edges are
    manifold (used twice), each triangle is the other's neighbour across all three sides;
    triangles on a non-manifold edge are compared by their sorted vertex triples.
    """
    nb = face_neighbours(table, len(F))
    twin = (nb[:, 0] >= 0) & (nb[:, 0] == nb[:, 1]) & (nb[:, 1] == nb[:, 2])
    count = int(np.count_nonzero(twin)) // 2
    sc = table.side_count()
    shared = (sc[:, 0] > 2) | (sc[:, 1] > 2) | (sc[:, 2] > 2)
    if shared.any():
        sub = np.sort(F[shared], axis=1)
        count += len(sub) - len(unique_rows(sub)[0])
    return count


@dataclass
class PreparedMesh:
    """A mesh after preparation (module docstring) with what was derived on the way.

    vertices (n, 3) float64; faces (m, 3) int64 (oriented); info: the preparation record;
    table: topology.EdgeTable of the faces; measures: face_geometry.FaceMeasures; quality:
    the quality record (quality.mesh_quality) when prepared with it, else None;
    quality_seconds: the wall time its measurement took; rows: the vertices' (3, n)
    coordinate rows (face_geometry.coordinate_rows) that the block passes read.
    """

    vertices: np.ndarray
    faces: np.ndarray
    info: dict
    table: object
    measures: object
    quality: dict = None
    quality_seconds: float = 0.0
    rows: np.ndarray = None

    def to_trimesh(self):
        """trimesh.Trimesh of the prepared mesh with metadata['hullprod'] = info."""
        mesh = require_trimesh("a trimesh.Trimesh result").Trimesh(vertices=self.vertices, faces=self.faces, process=False, validate=False)
        mesh.metadata["hullprod"] = self.info
        return mesh


def prepare_mesh(vertices, faces, source):
    """Checks, exact weld, degenerate removal, diagnosis and orientation (module docstring).

    Works on copies. Returns a trimesh.Trimesh with metadata['hullprod'].
    """
    return prepare(vertices, faces, source).to_trimesh()


def prepare(vertices, faces, source, progress=None, with_quality=False):
    """prepare_mesh's work: a PreparedMesh. faces None: vertices are a triangle soup.
    progress(fraction within the loading, message) is told of each step. with_quality:
    also the quality record (quality.mesh_quality), measured on a second thread while the
    winding is made consistent, and again after it should any face have been reversed."""
    progress = progress or (lambda fraction, message: None)
    where = source.get("path") or source.get("name") or source.get("label") or source.get("kind")
    V, F = check_raw_arrays(vertices, faces, where)
    n_in = V.size // 3
    m_in = n_in // 3 if F is None else len(F)
    info = {"source": dict(source), "input_vertices": int(n_in), "input_faces": int(m_in)}
    progress(0.2, "welding %d vertices" % n_in)
    V, F, merged = weld_exact(V, F)
    info["welded_vertices"] = int(merged)
    progress(0.4, "triangle measures and edges of %d faces" % len(F))
    with ThreadPoolExecutor(max_workers=1) as pool:   # the edges beside the measures
        table = pool.submit(edge_table, F, len(V))
        rows = coordinate_rows(V)                     # for every block pass from here on
        measures = face_measures(V, F, rows)
        table = table.result()
    bad = measures.degenerate
    info["degenerate_faces_removed"] = int(np.count_nonzero(bad))
    if bad.all():
        raise InputError("all %d triangles of %s are degenerate (zero area); nothing to assess"
                         % (len(F), where))
    if bad.any():
        F = F[~bad]
        measures = measures.take(~bad)
        table = None
    used = np.zeros(len(V), dtype=bool)
    used[F.ravel()] = True
    info["unreferenced_vertices_removed"] = int(np.count_nonzero(~used))
    if not used.all():
        remap = np.cumsum(used) - 1
        V, F = V[used], remap[F]
        rows = coordinate_rows(V)
        if table is not None:   # the same edges in the same order, on the vertices kept
            table.edges = remap[table.edges].astype(table.edges.dtype)
    del used
    if table is None:
        progress(0.6, "edges of %d faces" % len(F))
        table = edge_table(F, len(V))
    info["edges"] = int(len(table.count))
    info["boundary_edges"] = int(np.count_nonzero(table.count == 1))
    info["nonmanifold_edges"] = int(np.count_nonzero(table.count > 2))
    if info["nonmanifold_edges"] == info["edges"]:
        raise InputError("every edge of %s is shared by more than two triangles; no usable surface"
                         % where)
    progress(0.8, "orientation and quality record" if with_quality else "orientation")
    measured, seconds = None, 0.0
    with ThreadPoolExecutor(max_workers=1) as pool:  # a thread only if a record is measured
        # the quality record measured beside the orientation: it stands if no face turns
        side = (pool.submit(_timed, measured_record, V, F, table, measures, rows)
                if with_quality else None)
        info["duplicate_faces"] = duplicate_face_count(F, table)
        F, orient, reversed_faces = orient_faces(V, F, table, rows)
        if side is not None:
            measured, seconds = side.result()
    if reversed_faces.any():
        table.flip_faces(reversed_faces)
        # the measures of the reversed faces as their new winding gives them
        measures.put(reversed_faces, face_measures(V, F[reversed_faces], rows))
        measured = None
    info.update(orient)
    info["vertices"] = int(len(V))
    info["faces"] = int(len(F))
    quality = None
    if with_quality:
        if measured is None:
            measured, seconds = _timed(measured_record, V, F, table, measures, rows)
        quality = finished_record(measured, info, table)
    return PreparedMesh(V, F, info, table, measures, quality, seconds, rows)


def _timed(fn, *args):
    t = time.perf_counter()
    return fn(*args), time.perf_counter() - t


def check_raw_arrays(vertices, faces, where="the mesh"):
    """check_arrays_finite for vertices kept in their stored float type (float32 or
    float64, not converted) and faces None (a triangle soup: its (m, 3, 3) corners or
    3m vertex rows)."""
    V = vertices
    if not (isinstance(V, np.ndarray) and V.dtype in (np.float32, np.float64)):
        V = check_arrays(vertices, np.zeros((0, 3), np.int64), where)[0]
    soup = faces is None and V.ndim == 3 and V.shape[1:] == (3, 3)
    if not soup and (V.ndim != 2 or V.shape[1] != 3):
        raise InputError("%s: vertices must be an (n, 3) array, got shape %s" % (where, V.shape))
    if faces is None:
        if not soup and len(V) % 3:
            raise InputError("%s: a triangle soup needs 3 vertices a triangle, got %d" % (where, len(V)))
        check_finite(V, where)
        if len(V) == 0:
            raise InputError("%s has no triangles (empty mesh)" % where)
        return V, None
    if V.dtype == np.float64:
        V, F = check_arrays_finite(V, faces, where)
        return V, F
    check_finite(V, where)
    F = check_faces(faces, len(V), where)
    if len(F) == 0:
        raise InputError("%s has no triangles (empty mesh)" % where)
    return V, F


def check_arrays_finite(vertices, faces, where="the mesh"):
    """check_arrays plus: at least one face (InputError otherwise)."""
    V, F = check_arrays(vertices, faces, where)
    if len(F) == 0:
        raise InputError("%s has no triangles (empty mesh)" % where)
    return V, F


def file_record(path):
    """sha256 and size of a mesh file (for the assessment's input record)."""
    return {"sha256": sha256_file(path), "size_bytes": os.path.getsize(path)}
