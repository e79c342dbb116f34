"""Mesh input: STL (binary and ASCII), OBJ, PLY, arrays, trimesh and FreeCAD meshes; bad
input gives InputError or a recorded diagnosis; the caller's objects are never modified;
the public meshes of ../shared/hulls/mesh read to finite values with provenance."""
import os

import numpy as np
import pytest
import trimesh

from conftest import needs_freecad, shared_hull
from hullprod_wb.core.constants import METRICS
from hullprod_wb.core.errors import InputError
from hullprod_wb.core.inputs import sha256_file
from hullprod_wb.core.validity import Status
from hullprod_wb.examples.analytic_meshes import half_wigley_mesh, icosphere_mesh, plane_mesh, torus_mesh
from hullprod_wb.mesh.backend import assess_mesh
from hullprod_wb.mesh.loading import load_mesh, mesh_from_arrays, mesh_from_freecad, mesh_from_trimesh

FORMATS = [("stl", "binary.stl"), ("stl_ascii", "ascii.stl"), ("obj", "mesh.obj"), ("ply", "mesh.ply")]


def export(tmp_path, V, F, file_type, name):
    path = os.path.join(str(tmp_path), name)
    trimesh.Trimesh(V, F, process=False).export(path, file_type=file_type)
    return path


@pytest.mark.parametrize("file_type,name", FORMATS)
def test_formats_round_trip(tmp_path, file_type, name):
    V, F = half_wigley_mesh(32, 8, "random", grading=0.3)
    path = export(tmp_path, V, F, file_type, name)
    m = load_mesh(path)
    info = m.metadata["hullprod"]
    assert len(m.vertices) == len(V) and len(m.faces) == len(F)
    if file_type.startswith("stl"):
        # STL stores three corners per triangle: they must be welded back to shared vertices
        assert info["input_vertices"] == 3 * len(F)
        assert info["welded_vertices"] == 3 * len(F) - len(V)
    assert info["degenerate_faces_removed"] == 0 and info["orientation_changed"] is False
    ref = assess_mesh((V, F), lref=1.0, with_fields=False)
    r = assess_mesh(path, lref=1.0, with_fields=False)
    assert r.input["path"] == os.path.abspath(path)
    assert r.input["sha256"] == sha256_file(path) and r.input["format"] == file_type.split("_")[0]
    assert r.input["representation"] == "mesh"
    # STL and this PLY writer store float32 (relative rounding 6e-8), OBJ 8 decimals; the
    # curvature divides coordinate differences by edge lengths of ~0.008, so values agree
    # to about 1e-5 relative.
    for mname in METRICS:
        assert r.validity[mname].value == pytest.approx(ref.validity[mname].value, rel=1e-4, abs=1e-6)


def test_missing_file():
    with pytest.raises(InputError, match="not found"):
        load_mesh("/nonexistent/hull.stl")


def test_unknown_extension(tmp_path):
    p = tmp_path / "hull.xyz"
    p.write_text("1 2 3\n")
    with pytest.raises(InputError, match="unknown mesh format"):
        load_mesh(str(p))
    with pytest.raises(InputError, match="unknown mesh format"):
        assess_mesh(str(p))


def test_empty_file(tmp_path):
    p = tmp_path / "empty.stl"
    p.write_bytes(b"")
    with pytest.raises(InputError, match="empty"):
        load_mesh(str(p))


def test_directory_is_not_a_file(tmp_path):
    d = tmp_path / "folder.stl"
    d.mkdir()
    with pytest.raises(InputError, match="not a file"):
        load_mesh(str(d))


@pytest.mark.parametrize("name,content", [
    ("garbage.stl", b"\x00\x01garbage" * 20),
    ("nothing.stl", b"solid x\nendsolid x\n"),
    ("text.obj", b"this is not a mesh\n"),
    ("broken.ply", b"ply\nformat ascii 1.0\nelement vertex 3\nend_header\n1 2\n"),
])
def test_unreadable_or_faceless_file(tmp_path, name, content):
    p = tmp_path / name
    p.write_bytes(content)
    with pytest.raises(InputError) as exc:
        load_mesh(str(p))
    msg = str(exc.value)
    assert str(p) in msg and "\n" not in msg
    assert "no triangles" in msg or "cannot read" in msg


def test_nan_coordinates(tmp_path):
    V, F = plane_mesh(4)
    V[5, 2] = np.nan
    with pytest.raises(InputError, match="NaN or infinite"):
        mesh_from_arrays(V, F)
    V[5, 2] = np.inf
    with pytest.raises(InputError, match="NaN or infinite"):
        assess_mesh((V, F))
    p = tmp_path / "nan.stl"
    p.write_text("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 nan\n"
                 "vertex 0 1 0\nendloop\nendfacet\nendsolid x\n")
    with pytest.raises(InputError, match="NaN or infinite"):
        load_mesh(str(p))
    b = tmp_path / "nan_binary.stl"      # read as a view of the mapped file
    trimesh.Trimesh(plane_mesh(1)[0], [[0, 1, 2], [1, 3, 2]], process=False).export(str(b))
    data = bytearray(b.read_bytes())
    data[84 + 50 + 12 + 12 + 4:84 + 50 + 12 + 12 + 8] = np.float32(np.nan).tobytes()  # triangle 2, corner 2, y
    b.write_bytes(bytes(data))
    with pytest.raises(InputError, match="NaN or infinite coordinates at 1 of its 6 vertices"):
        load_mesh(str(b))


def test_bad_arrays():
    V, F = plane_mesh(2)
    with pytest.raises(InputError, match=r"\(n, 3\)"):
        mesh_from_arrays(V[:, :2], F)
    with pytest.raises(InputError, match="outside"):
        mesh_from_arrays(V, F + len(V))
    with pytest.raises(InputError, match="no triangles"):
        mesh_from_arrays(V, np.zeros((0, 3), dtype=int))


def test_degenerate_triangles_removed_and_counted(tmp_path):
    V, F = plane_mesh(6)
    n = len(V)
    # a repeated-vertex triangle, and a zero-area one through a new point on the edge 0-1
    V2 = np.vstack([V, 0.5 * (V[0] + V[1])])
    extra = np.array([[0, 0, 1], [0, 1, n]])
    F2 = np.vstack([F, extra])
    m = mesh_from_arrays(V2, F2)
    info = m.metadata["hullprod"]
    assert info["degenerate_faces_removed"] == 2
    assert info["unreferenced_vertices_removed"] == 1   # the collinear point is used by no other triangle
    assert len(m.faces) == len(F) and len(m.vertices) == n
    r = assess_mesh((V2, F2), lref=2.0)
    assert r.provenance["preparation"]["degenerate_faces_removed"] == 2
    assert any("degenerate" in w for w in r.warnings)
    assert r.provenance["quality"]["advisory"] in ("caution", "poor")
    # all degenerate: nothing usable
    with pytest.raises(InputError, match="degenerate"):
        mesh_from_arrays(V2, extra)
    p = export(tmp_path, V2, F2, "stl", "degenerate.stl")
    assert load_mesh(p).metadata["hullprod"]["degenerate_faces_removed"] == 2


def test_non_manifold_edge_is_diagnosed():
    V, F = icosphere_mesh(6)
    # a small closed tetrahedron standing on the sphere edge (a, b): that edge then has
    # four triangles, and a, b are non-manifold vertices without being on a boundary
    a, b = F[0, 0], F[0, 1]
    mid = 0.5 * (V[a] + V[b])
    c, d = 1.3 * mid + [0.02, 0.0, 0.0], 1.3 * mid - [0.02, 0.0, 0.0]
    n = len(V)
    V2 = np.vstack([V, c, d])
    tet = np.array([[a, b, n], [b, a, n + 1], [a, n, n + 1], [b, n + 1, n]])
    F2 = np.vstack([F, tet])
    m = mesh_from_arrays(V2, F2)
    assert m.metadata["hullprod"]["nonmanifold_edges"] == 1
    assert m.metadata["hullprod"]["boundary_edges"] == 0
    r = assess_mesh((V2, F2), lref=2.0)
    q = r.provenance["quality"]
    assert q["nonmanifold"]["edges"] == 1 and q["nonmanifold"]["vertices"] == 2
    assert q["advisory"] == "poor" and not q["watertight"]
    assert not r.fields.valid[a] and not r.fields.valid[b]
    assert r.validity["I_D"].status == Status.MESH_SENSITIVE
    ex = r.validity["I_D"].evidence["excluded"]
    assert ex["nonmanifold_vertices"] == 2 and ex["boundary_vertices"] == 0
    assert any("non-manifold" in w for w in r.warnings)
    # nothing but non-manifold edges (one triangle stored three times): no usable surface
    P = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]])
    with pytest.raises(InputError, match="more than two"):
        mesh_from_arrays(P, np.array([[0, 1, 2]] * 3))


def test_orientation_fixed_on_a_copy():
    V, F = icosphere_mesh(6)
    rng = np.random.default_rng(2)
    flip = rng.random(len(F)) < 0.3
    G = F.copy()
    G[flip] = G[flip][:, ::-1]
    G_before = G.copy()
    V_before = V.copy()
    m = mesh_from_arrays(V, G)
    info = m.metadata["hullprod"]
    assert np.array_equal(G, G_before) and np.array_equal(V, V_before)   # caller's arrays untouched
    assert info["winding_flipped_faces"] == int(flip.sum())
    assert info["orientation_changed"] is True
    assert np.array_equal(m.faces, F)                                     # the majority winding kept
    # the whole sphere inside out: closed, so it is turned outward and H < 0 (eq:brephk sign)
    m2 = mesh_from_arrays(V, F[:, ::-1])
    assert m2.metadata["hullprod"]["inverted_closed_pieces"] == 1
    r = assess_mesh((V, G), lref=2.0)
    assert r.validity["I_D"].value == pytest.approx(4.0, rel=1e-10)
    assert np.allclose(r.fields.H, -1.0, atol=1e-10)
    assert r.provenance["orientation"]["winding_flipped_faces"] == int(flip.sum())


def test_trimesh_input_not_modified():
    V, F = torus_mesh(8)
    F = F.copy()
    F[::7] = F[::7][:, ::-1]
    tm = trimesh.Trimesh(V, F, process=False)
    faces_before = np.array(tm.faces)
    verts_before = np.array(tm.vertices)
    m = mesh_from_trimesh(tm)
    assert m is not tm
    assert np.array_equal(tm.faces, faces_before) and np.array_equal(tm.vertices, verts_before)
    r = assess_mesh(tm, lref=8.0, with_fields=False)
    assert np.array_equal(tm.faces, faces_before)
    assert r.input["format"] == "trimesh" and r.provenance["orientation"]["orientation_changed"]


def test_welding_is_exact():
    """Only bit-identical points are merged: a vertex 1e-12 away stays separate."""
    V, F = plane_mesh(2)
    Vs = V[F].reshape(-1, 3).copy()                       # unshared corners, like STL
    Fs = np.arange(len(Vs)).reshape(-1, 3)
    m = mesh_from_arrays(Vs, Fs)
    assert len(m.vertices) == len(V)
    centre = np.flatnonzero(np.all(Vs == 0.0, axis=1))
    assert len(centre) > 1                                 # the centre is a corner of several triangles
    Vs[centre[0], 0] += 1e-12
    m2 = mesh_from_arrays(Vs, Fs)
    assert len(m2.vertices) == len(V) + 1
    Vneg = Vs.copy()
    Vneg[Vneg == 0.0] = -0.0                              # -0.0 and 0.0 are the same point
    assert len(mesh_from_arrays(Vneg, Fs).vertices) == len(V) + 1


@needs_freecad
def test_freecad_mesh():
    from hullprod_wb.freecad_env import import_freecad
    FreeCAD = import_freecad()
    import Mesh
    V, F = half_wigley_mesh(24, 6)
    fm = Mesh.Mesh([[FreeCAD.Vector(*V[i]) for i in tri] for tri in F])
    m = mesh_from_freecad(fm)
    assert len(m.vertices) == len(V) and len(m.faces) == len(F)
    ref = assess_mesh((V, F), lref=1.0, with_fields=False)
    r = assess_mesh(fm, lref=1.0, with_fields=False)
    assert r.input["format"] == "FreeCAD mesh"
    # FreeCAD's mesh kernel stores points in float32 (relative rounding 6e-8), amplified
    # by the curvature's division by edge lengths of ~0.01: agreement to ~1e-6 relative.
    for mname in METRICS:
        assert r.validity[mname].value == pytest.approx(ref.validity[mname].value, rel=1e-5, abs=1e-7)
    # a document object: the points come with its placement applied
    doc = FreeCAD.newDocument("hullprod_mesh_test")
    try:
        obj = doc.addObject("Mesh::Feature", "Hull")
        obj.Mesh = fm
        obj.Placement.Base = FreeCAD.Vector(10.0, 0.0, 0.0)
        doc.recompute()
        moved = mesh_from_freecad(obj)
        assert moved.metadata["hullprod"]["source"]["object"] == "Hull"
        assert np.allclose(np.sort(moved.vertices[:, 0]), np.sort(m.vertices[:, 0]) + 10.0, atol=1e-6)
    finally:
        FreeCAD.closeDocument(doc.Name)
    with pytest.raises(InputError):
        mesh_from_freecad(object())


@pytest.mark.parametrize("name", ["wigley_full.stl", "dtmb5415_full_coarse.stl", "dtmb5512_full.obj",
                                  "box_barge.obj"])
def test_public_meshes(name):
    path = shared_hull("mesh/" + name)
    r = assess_mesh(path)
    assert r.input["sha256"] == sha256_file(path)
    for m in METRICS:
        rec = r.validity[m]
        assert rec.status in (Status.VALID, Status.MESH_SENSITIVE)
        assert np.isfinite(rec.value)
        assert rec.evidence["quality_advisory"] in ("good", "caution", "poor")
    assert sum(r.validity[m].value for m in METRICS[3:]) == pytest.approx(1.0, abs=1e-12)
    p = r.provenance
    assert p["quality"]["counts"]["faces"] == p["mesh_counts"]["faces"] > 0
    assert "orientation_changed" in p["orientation"] and p["preparation"]["source"]["path"] == os.path.abspath(path)
    assert 0 < r.integrals.valid_area <= r.integrals.represented_area
    r.to_json()


def _four_values(words):
    """A hash with four values: nearly every row collides with others."""
    return words[0] & np.uint64(3)


@pytest.mark.parametrize("rounds", [64, 1])
def test_unique_rows_exact_even_with_hash_collisions(monkeypatch, rounds):
    """Colliding hashes take more rounds of the table (64) or end in the exact sort (1)."""
    import hullprod_wb.mesh.weld as W
    rng = np.random.default_rng(4)
    B = rng.integers(0, 5, size=(500, 3)).astype(np.int64)
    first, inverse = W.unique_rows(B)
    assert np.array_equal(B[first][inverse], B)
    assert np.array_equal(first, np.sort(np.unique(B, axis=0, return_index=True)[1]))
    monkeypatch.setattr(W, "row_hashes", _four_values)
    monkeypatch.setattr(W, "hash_slots", lambda words, bits: _four_values(words).astype(np.intp))
    monkeypatch.setattr(W, "MAX_ROUNDS", rounds)
    f2, i2 = W.unique_rows(B)
    assert np.array_equal(f2, first) and np.array_equal(i2, inverse)


def test_file_hash_follows_the_file(tmp_path):
    """The input record's SHA-256 is computed once a file, and again when the file changes."""
    import hashlib
    p = tmp_path / "m.stl"
    for k, content in enumerate((b"solid a\nendsolid a\n", b"solid b\nendsolid b\n")):
        p.write_bytes(content)
        os.utime(p, ns=(10**18 + k, 10**18 + k))
        assert sha256_file(str(p)) == hashlib.sha256(content).hexdigest()


def test_no_thread_is_left_once_the_work_is_done(tmp_path):
    """The file's digest and the mesh path's threads end with their work, so that the
    process may fork worker processes afterwards (core.processes forks only a process
    with one thread)."""
    import threading
    from hullprod_wb.core.inputs import start_sha256
    from hullprod_wb.mesh.backend import assess_mesh
    V, F = torus_mesh(12)
    p = str(tmp_path / "t.ply")
    trimesh.Trimesh(V, F, process=False).export(p)
    start_sha256(p).result()
    assess_mesh(p)
    alive = [t for t in threading.enumerate() if t.name.startswith("hullprod") and t.is_alive()]
    for t in alive:            # the background import may be finishing its last line
        t.join(5)
    assert not [t.name for t in alive if t.is_alive()]
    assert not [t.name for t in threading.enumerate() if t.name.startswith(("hullprod-sha256", "ThreadPool"))]


def test_the_command_begins_a_mesh_files_digest_before_loading_the_backend(tmp_path):
    """`analyze FILE` of a mesh file begins the file's digest at once (cli.early_reading),
    and the mesh path takes that digest up rather than hashing the file again."""
    import hashlib
    from hullprod_wb import cli
    from hullprod_wb.core import inputs
    V, F = torus_mesh(12)
    p = str(tmp_path / "t.ply")
    trimesh.Trimesh(V, F, process=False).export(p)
    assert cli.early_reading(["analyze", p, "--lref", "3", "--json"]) is None
    st = os.stat(p)
    early = inputs._DIGESTS.get((os.path.abspath(p), st.st_size, st.st_mtime_ns))
    assert early is not None
    assert inputs.start_sha256(p) is early
    assert early.result() == hashlib.sha256(open(p, "rb").read()).hexdigest()
    for argv in (["analyze", str(tmp_path / "missing.stl")], ["example"]):
        assert cli.early_reading(argv) is None
    assert not any(k[0].endswith("missing.stl") for k in inputs._DIGESTS)


def test_an_error_trimesh_catches_and_logs_refuses_the_file(tmp_path, monkeypatch):
    """A parse error trimesh's reader catches itself and logs with its traceback (numpy 2.4's
    fromstring on damaged facet normals) is a damaged file: InputError naming the file, the
    reader's message and the exception; nothing is printed."""
    import logging

    import trimesh.exchange.stl as stl
    from hullprod_wb.mesh.readers import read_stl

    def load_stl(fh):
        try:
            raise ValueError("string or file could not be read to its end due to unmatched data")
        except ValueError:
            logging.getLogger("trimesh").warning("failed to extract face_normals", exc_info=True)
        return {"vertices": np.zeros((3, 3)), "faces": np.array([[0, 1, 2]])}

    monkeypatch.setattr(stl, "load_stl", load_stl)
    logger = logging.getLogger("trimesh")
    before = (logger.propagate, list(logger.handlers))
    path = tmp_path / "damaged.stl"
    path.write_text("solid x\nfacet normal 0 0 @\nendsolid x\n")
    with pytest.raises(InputError) as err:
        read_stl(str(path))
    message = str(err.value)
    assert str(path) in message and "failed to extract face_normals" in message and "ValueError" in message
    assert (logger.propagate, logger.handlers) == before  # trimesh's logging as it was
