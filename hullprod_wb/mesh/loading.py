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

The record of all this is ``mesh.metadata['hullprod']`` of the returned trimesh.Trimesh.
"""
import os

import numpy as np

from ..core.errors import InputError
from ..core.inputs import MESH_FORMATS, sha256_file
from .curvature import DEGENERATE_RTOL, check_arrays
from .topology import edge_table, face_pairs


def _trimesh():
    try:
        import trimesh
    except ImportError as exc:  # pragma: no cover - trimesh is a declared dependency
        raise InputError("reading mesh files needs the Python package trimesh (%s)" % exc) from None
    return trimesh


def check_mesh_path(path):
    """Return (absolute path, format) of a readable, non-empty .stl/.obj/.ply file."""
    if not isinstance(path, (str, os.PathLike)):
        raise InputError("expected a mesh file path, got %r" % (path,))
    path = os.fspath(path)
    if not os.path.exists(path):
        raise InputError("mesh file not found: %s" % path)
    if not os.path.isfile(path):
        raise InputError("mesh input is not a file: %s" % path)
    ext = os.path.splitext(path)[1].lower()
    if ext not in MESH_FORMATS:
        raise InputError("unknown mesh format '%s' for %s (known: %s)"
                         % (ext or "no extension", path, ", ".join(sorted(MESH_FORMATS))))
    if os.path.getsize(path) == 0:
        raise InputError("mesh file is empty: %s" % path)
    return os.path.abspath(path), MESH_FORMATS[ext]


def load_mesh(path):
    """Read an STL (ASCII or binary), OBJ or PLY file and prepare it (module docstring).

    Returns a trimesh.Trimesh whose metadata['hullprod'] records the preparation.
    """
    path, fmt = check_mesh_path(path)
    trimesh = _trimesh()
    try:
        if fmt == "stl":  # the STL reader itself: no scene, cache or copy overhead
            from trimesh.exchange.stl import load_stl
            with open(path, "rb") as fh:
                kw = load_stl(fh)
            vertices, faces = kw["vertices"], kw["faces"]
        else:
            loaded = trimesh.load(path, file_type=fmt, force="mesh", process=False)
            if not isinstance(loaded, trimesh.Trimesh):
                raise InputError("mesh file %s holds no triangle mesh" % path)
            vertices, faces = loaded.vertices, loaded.faces
    except InputError:
        raise
    except Exception as exc:  # the readers raise many kinds of errors for unreadable files
        raise InputError("cannot read mesh file %s as %s: %s" % (path, fmt.upper(), exc)) from None
    source = {"kind": "file", "path": path, "format": fmt}
    return prepare_mesh(vertices, faces, source)


def mesh_from_arrays(vertices, faces, name="arrays"):
    """Prepare a mesh from (n, 3) float vertices and (m, 3) int faces (copied, not modified)."""
    V, F = check_arrays(np.array(vertices, dtype=float, copy=True), np.array(faces, copy=True))
    return prepare_mesh(V, F, {"kind": "arrays", "name": name})


def mesh_from_trimesh(mesh):
    """Prepare a copy of a trimesh.Trimesh (the caller's object is not modified)."""
    source = {"kind": "trimesh"}
    if getattr(mesh, "metadata", None) and "file_name" in mesh.metadata:
        source["name"] = mesh.metadata["file_name"]
    return prepare_mesh(np.array(mesh.vertices, dtype=float), np.array(mesh.faces), source)


def mesh_from_freecad(obj):
    """Prepare a FreeCAD Mesh.Mesh, or a document object with a Mesh property.

    The points come from Mesh.Topology, which has the object's placement applied.
    """
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
    return prepare_mesh(V, F, source)


_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)


def _mix(z):
    """64-bit finaliser (xor-shift-multiply) of uint64 z, in place."""
    z ^= z >> np.uint64(30)
    z *= _MIX1
    z ^= z >> np.uint64(27)
    z *= _MIX2
    z ^= z >> np.uint64(31)
    return z


def unique_rows(B):
    """Exact unique rows of a (k, c) array of 64-bit values.

    Rows are hashed to one uint64 and sorted once; the grouping is then checked against
    the rows themselves and, should two different rows share a hash, redone with numpy's
    exact (slower) row sort. Returns (first (u,) index of each distinct row's first
    occurrence, inverse (k,) group of every row), groups numbered by first occurrence.
    """
    B = np.ascontiguousarray(B).view(np.uint64)
    with np.errstate(over="ignore"):
        h = _mix(B[:, 0].copy())
        for col in range(1, B.shape[1]):
            h ^= B[:, col]
            h = _mix(h)
    order = np.argsort(h)
    hs = h[order]
    new = np.empty(len(hs), dtype=bool)
    new[:1] = True
    np.not_equal(hs[1:], hs[:-1], out=new[1:])
    starts = np.flatnonzero(new)
    first = np.minimum.reduceat(order, starts) if len(order) else order
    inverse = np.empty(len(h), dtype=np.int64)
    inverse[order] = np.cumsum(new) - 1
    if not np.array_equal(B[first[inverse]], B):      # a hash collision: exact fallback
        rows = B.view(np.dtype((np.void, B.dtype.itemsize * B.shape[1]))).ravel()
        _, first, inverse = np.unique(rows, return_index=True, return_inverse=True)
        inverse = inverse.ravel()
    rank = np.empty(len(first), dtype=np.int64)
    by_first = np.argsort(first, kind="stable")
    rank[by_first] = np.arange(len(first))
    return first[by_first], rank[inverse]


def weld_exact(V, F):
    """Merge vertices with bit-identical coordinates (-0.0 equals 0.0), keeping the order of
    first occurrence. Returns (vertices, faces, number merged)."""
    Vc = np.ascontiguousarray(V, dtype=np.float64) + 0.0
    first, inverse = unique_rows(Vc)
    return Vc[first], inverse[F], len(V) - len(first)


def degenerate_faces(V, F):
    """(m,) bool: triangles with a repeated vertex or 2A <= DEGENERATE_RTOL * (longest edge)^2."""
    P = V[F]
    e = P[:, [1, 2, 0]] - P
    l2 = np.einsum("ijk,ijk->ij", e, e)
    dblA = np.linalg.norm(np.cross(e[:, 0], e[:, 1]), axis=1)
    repeated = (F[:, 0] == F[:, 1]) | (F[:, 1] == F[:, 2]) | (F[:, 2] == F[:, 0])
    return repeated | ~(dblA > DEGENERATE_RTOL * l2.max(axis=1))


def orient_faces(V, F, table):
    """Consistent winding across manifold edges; closed pieces turned outward.

    Each triangle f gets two nodes, f (kept) and f + m (flipped); an edge whose two
    triangles agree joins f-g and f+m-g+m, one where they disagree joins f-(g+m) and
    (f+m)-g. In a piece that can be oriented the two nodes of a triangle fall into two
    different components; the component holding more kept nodes wins. A piece with no
    boundary and no non-manifold edge is then flipped as a whole if its signed volume
    sum(p0 . (p1 x p2))/6 is negative. Returns (faces, info dict).
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    m = len(F)
    pairs, same = face_pairs(F, table)
    a, b = pairs[:, 0], pairs[:, 1]
    rows = np.concatenate([a, a + m])
    cols = np.concatenate([np.where(same, b + m, b), np.where(same, b, b + m)])
    graph = coo_matrix((np.ones(len(rows), dtype=np.int8), (rows, cols)), shape=(2 * m, 2 * m))
    _, label = connected_components(graph, directed=False)
    keep, alt = label[:m], label[m:]
    nkeep = np.bincount(keep, minlength=label.max() + 1)
    flip = (nkeep[alt] > nkeep[keep]) | ((nkeep[alt] == nkeep[keep]) & (alt < keep))
    non_orientable = keep == alt
    out = F.copy()
    out[flip] = out[flip][:, ::-1]
    # pieces: the unordered pair of double-cover components
    piece = np.unique(np.minimum(keep, alt), return_inverse=True)[1]
    npieces = int(piece.max()) + 1 if m else 0
    open_edge = table.count[table.side_edge] != 2          # (m, 3)
    piece_open = np.bincount(piece, weights=open_edge.any(axis=1) | non_orientable, minlength=npieces) > 0
    P = V[out]
    vol = np.einsum("ij,ij->i", P[:, 0], np.cross(P[:, 1], P[:, 2])) / 6.0
    piece_vol = np.bincount(piece, weights=vol, minlength=npieces)
    invert_piece = ~piece_open & (piece_vol < 0)
    inv = invert_piece[piece]
    out[inv] = out[inv][:, ::-1]
    info = {
        "winding_flipped_faces": int(np.count_nonzero(flip)),
        "inverted_closed_pieces": int(np.count_nonzero(invert_piece)),
        "inverted_faces": int(np.count_nonzero(inv)),
        "non_orientable_faces": int(np.count_nonzero(non_orientable)),
        "pieces": npieces,
        "closed_pieces": int(np.count_nonzero(~piece_open)),
    }
    info["orientation_changed"] = bool(np.any(flip ^ inv))
    return out, info


def prepare_mesh(vertices, faces, source):
    """Checks, exact weld, degenerate removal, diagnosis and orientation (module docstring).

    Works on copies. Returns a trimesh.Trimesh with metadata['hullprod'].
    """
    trimesh = _trimesh()
    where = source.get("path") or source.get("name") or source.get("label") or source.get("kind")
    V, F = check_arrays_finite(vertices, faces, where)
    info = {"source": dict(source), "input_vertices": int(len(V)), "input_faces": int(len(F))}
    V, F, merged = weld_exact(V, F)
    info["welded_vertices"] = int(merged)
    bad = degenerate_faces(V, F)
    info["degenerate_faces_removed"] = int(np.count_nonzero(bad))
    if bad.all():
        raise InputError("all %d triangles of %s are degenerate (zero area); nothing to assess"
                         % (len(F), where))
    F = F[~bad]
    used = np.zeros(len(V), dtype=bool)
    used[F.ravel()] = True
    info["unreferenced_vertices_removed"] = int(np.count_nonzero(~used))
    if not used.all():
        remap = np.cumsum(used) - 1
        V, F = V[used], remap[F]
    table = edge_table(F, len(V))
    info["edges"] = int(len(table.count))
    info["boundary_edges"] = int(np.count_nonzero(table.count == 1))
    info["nonmanifold_edges"] = int(np.count_nonzero(table.count > 2))
    if info["nonmanifold_edges"] == info["edges"]:
        raise InputError("every edge of %s is shared by more than two triangles; no usable surface"
                         % where)
    info["duplicate_faces"] = int(len(F) - len(unique_rows(np.sort(F, axis=1))[0]))
    F, orient = orient_faces(V, F, table)
    info.update(orient)
    info["vertices"] = int(len(V))
    info["faces"] = int(len(F))
    mesh = trimesh.Trimesh(vertices=V, faces=F, process=False, validate=False)
    mesh.metadata["hullprod"] = info
    return mesh


def check_arrays_finite(vertices, faces, where="the mesh"):
    """check_arrays plus: at least one face (InputError otherwise)."""
    V, F = check_arrays(vertices, faces, where)
    if len(F) == 0:
        raise InputError("%s has no triangles (empty mesh)" % where)
    return V, F


def file_record(path):
    """sha256 and size of a mesh file (for the assessment's input record)."""
    return {"sha256": sha256_file(path), "size_bytes": os.path.getsize(path)}
