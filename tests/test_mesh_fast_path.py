"""The fast mesh path against slower, direct references: the file readers against trimesh's
readers, welding, edge table, duplicates, orientation, triangle measures, normal variation
and distributions against mesh_reference, the quality record from the shared topology
against the one recomputed from scratch; the memory estimate and its refusal, progress."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest
import trimesh

import mesh_reference as ref
from conftest import ROOT
from hullprod_wb.core.errors import InputError
from hullprod_wb.examples.analytic_meshes import cylinder_mesh, half_wigley_mesh, icosphere_mesh, torus_mesh
from hullprod_wb.mesh import loading, memory, readers
from hullprod_wb.mesh.backend import assess_mesh
from hullprod_wb.mesh.face_geometry import edge_lengths, normal_angles, unit_normals
from hullprod_wb.mesh.quality import mesh_quality, summary
from hullprod_wb.mesh.topology import edge_table


def damaged_meshes():
    """Meshes with what real files bring: flipped and inverted windings, a non-manifold
    edge, duplicates (also on a non-manifold edge), two pieces, a degenerate triangle, an
    unused vertex, a Moebius strip, a scrambled vertex and face order."""
    rng = np.random.default_rng(11)
    out = {"torus": torus_mesh(14, pattern="random", seed=3),
           "wigley": half_wigley_mesh(20, 6, "random", grading=0.3),
           "cylinder": cylinder_mesh(16, 5, pattern="alternating")}
    V, F = icosphere_mesh(5)
    G = F.copy()
    flip = rng.random(len(F)) < 0.3
    G[flip] = G[flip][:, ::-1]
    out["flipped"] = (V, G)
    out["inside_out"] = (V, F[:, ::-1].copy())
    a, b = F[0, 0], F[0, 1]
    mid = 0.5 * (V[a] + V[b])
    n = len(V)
    V2 = np.vstack([V, 1.3 * mid + [0.02, 0, 0], 1.3 * mid - [0.02, 0, 0]])
    tet = [[a, b, n], [b, a, n + 1], [a, n, n + 1], [b, n + 1, n]]
    out["nonmanifold_dup"] = (V2, np.vstack([F, tet, F[3:6], [tet[0]]]))
    Vt, Ft = torus_mesh(8)
    out["two_pieces"] = (np.vstack([V, Vt + 5.0, [[9.0, 9.0, 9.0]]]), np.vstack([F, Ft + len(V), [[0, 0, 1]]]))
    u = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    w = np.linspace(-0.3, 0.3, 3)
    U, W = np.meshgrid(u, w, indexing="ij")
    P = np.stack([(1 + W * np.cos(U / 2)) * np.cos(U), (1 + W * np.cos(U / 2)) * np.sin(U), W * np.sin(U / 2)],
                 -1).reshape(-1, 3)
    Fm = []
    for i in range(24):
        i1 = (i + 1) % 24
        for j in range(2):
            jj, jj1 = (j, j + 1) if i1 else (2 - j, 1 - j)
            Fm += [[i * 3 + j, i1 * 3 + jj, i1 * 3 + jj1], [i * 3 + j, i1 * 3 + jj1, i * 3 + j + 1]]
    out["moebius"] = (P, np.array(Fm))
    V, F = torus_mesh(10, pattern="random", seed=5)
    perm = rng.permutation(len(V))
    inv = np.empty_like(perm)
    inv[perm] = np.arange(len(V))
    out["scrambled"] = (V[perm], inv[F][rng.permutation(len(F))])
    return out


MESHES = damaged_meshes()


@pytest.mark.parametrize("name", sorted(MESHES))
@pytest.mark.parametrize("file_type", ["stl", "ply", "obj", "stl_ascii", "ply_ascii"])
def test_readers_give_what_trimesh_reads(tmp_path, name, file_type):
    V, F = MESHES[name]
    ext = file_type.split("_")[0]
    path = str(tmp_path / ("m." + ext))
    kw = {"encoding": "ascii"} if file_type == "ply_ascii" else {}
    trimesh.Trimesh(V, F, process=False).export(path, file_type="ply" if file_type == "ply_ascii" else file_type,
                                                 **kw)
    fast = readers.read_mesh_file(path, ext)
    slow = readers._trimesh_reader(path, ext)
    faces = np.arange(3 * fast.n_faces).reshape(-1, 3) if fast.faces is None else fast.faces
    assert np.array_equal(np.asarray(fast.vertices, float).reshape(-1, 3), np.asarray(slow.vertices, float))
    assert np.array_equal(faces, slow.faces)


@pytest.mark.parametrize("text", [
    b"# a comment\n\nv 0 0 0\nv 1 0 0\n# between\nv 0 1 0\nv 5 5 5\nf 1 2 3\n\n",
    b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n",
    b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 4 3\n",                   # a quad: trimesh
    b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n",          # normals: trimesh
    b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n",                           # relative: trimesh
    b"v 0 0 0 1\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",                            # four values
    b"o hull\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
])
def test_obj_layouts(tmp_path, text):
    path = tmp_path / "m.obj"
    path.write_bytes(text)
    fast = readers.read_obj(str(path))
    slow = readers._trimesh_reader(str(path), "obj")
    assert np.array_equal(fast.vertices, slow.vertices) and np.array_equal(fast.faces, slow.faces)


@pytest.mark.parametrize("text, simple", [
    (b"v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2 3", True),        # CRLF, no last newline
    (b"v\t0 0  0 \n\nv 1 0 0\nv 0 1 0\nf 3 1 2\n", True),
    (b"v 0 0 0 1\nv 1 0 0\nv 0 1 0\nf 1 2\n", False),            # 5 + 4 + 4 + 3 tokens
    (b"v 0 0\n0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", False),           # a value on a line of its own
    (b" v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", False),            # a space before the keyword
    (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 \n7\n", False),
])
def test_simple_obj_takes_exactly_four_tokens_a_line(text, simple):
    """The block parser takes a file only when every keyword line holds exactly its keyword
    and three values and no other line holds any (trimesh reads the others)."""
    parsed = readers._simple_obj(text)
    assert (parsed is not None) == simple
    if simple:
        V, F = parsed
        assert V.shape == (3, 3) and F.shape == (1, 3) and sorted(F[0]) == [0, 1, 2]


def test_big_endian_and_extra_properties_ply(tmp_path):
    V, F = MESHES["torus"]
    for encoding, props in (("binary_big_endian", ""), ("binary_little_endian", "property uchar red\n")):
        end = ">" if "big" in encoding else "<"
        vd = [("x", end + "f4"), ("y", end + "f4"), ("z", end + "f4")] + ([("red", "u1")] if props else [])
        verts = np.zeros(len(V), dtype=vd)
        for j, c in enumerate("xyz"):
            verts[c] = V[:, j]
        faces = np.zeros(len(F), dtype=[("n", "u1"), ("i", end + "i4", (3,))])
        faces["n"], faces["i"] = 3, F
        header = ("ply\nformat %s 1.0\nelement vertex %d\nproperty float x\nproperty float y\n"
                  "property float z\n%selement face %d\nproperty list uchar int vertex_indices\nend_header\n"
                  % (encoding, len(V), props, len(F))).encode()
        path = str(tmp_path / ("m_%s.ply" % encoding))
        with open(path, "wb") as fh:
            fh.write(header + verts.tobytes() + faces.tobytes())
        fast = readers.read_ply(path)
        slow = readers._trimesh_reader(path, "ply")
        assert np.array_equal(np.asarray(fast.vertices, float), slow.vertices)
        assert np.array_equal(fast.faces, slow.faces)


@pytest.mark.parametrize("name", sorted(MESHES))
def test_preparation_against_the_reference(name):
    V, F = MESHES[name]
    soup = np.asarray(V, np.float32)[F].reshape(-1, 3)
    for args in ((V, F), (soup, None)):
        Vw, Fw, merged = loading.weld_exact(*args)
        Vr, Fr, mr = ref.weld(*args)
        assert np.array_equal(Vw, Vr) and np.array_equal(Fw, Fr) and merged == mr
    pm = loading.prepare(V, F, {"kind": "arrays"})
    # the reference steps on the welded, cleaned faces before orientation
    Vw, Fw, _ = ref.weld(V, F)
    area, q, amin, amax, bad = ref.triangle_measures(Vw, Fw)
    assert pm.info["degenerate_faces_removed"] == int(bad.sum())
    Fw = Fw[~bad]
    used = np.zeros(len(Vw), bool)
    used[Fw] = True
    Vw, Fw = Vw[used], (np.cumsum(used) - 1)[Fw]
    E, count, side_edge, pairs, same = ref.edges(Fw, len(Vw))
    t = edge_table(Fw, len(Vw))
    assert np.array_equal(t.edges, E) and np.array_equal(t.count, count)
    assert np.array_equal(t.side_edge, side_edge) and np.array_equal(t.pairs, pairs)
    assert np.array_equal(t.same_direction(Fw), same)
    assert pm.info["duplicate_faces"] == ref.duplicates(Fw)
    out, flips, inverted, bad_faces, pieces, closed = ref.orient(Vw, Fw, count, side_edge, pairs, same)
    assert np.array_equal(pm.vertices, Vw) and np.array_equal(pm.faces, out)
    assert (pm.info["winding_flipped_faces"], pm.info["inverted_faces"], pm.info["non_orientable_faces"],
            pm.info["pieces"], pm.info["closed_pieces"]) == (flips, inverted, bad_faces, pieces, closed)
    # the table follows the orientation: it is the table of the oriented faces
    E2, count2, side_edge2, pairs2, same2 = ref.edges(pm.faces, len(Vw))
    assert np.array_equal(pm.table.side_edge, side_edge2) and np.array_equal(pm.table.pairs, pairs2)
    assert np.array_equal(pm.table.same_direction(pm.faces), same2)
    # measures, bit for bit, of the oriented faces
    area, q, amin, amax, _ = ref.triangle_measures(pm.vertices, pm.faces)
    for fast, slow in ((pm.measures.area, area), (pm.measures.quality, q), (pm.measures.min_angle, amin),
                       (pm.measures.max_angle, amax)):
        assert np.array_equal(fast, slow, equal_nan=True)
    lengths = edge_lengths(pm.vertices, pm.table.edges)
    assert np.array_equal(lengths, np.linalg.norm(pm.vertices[E2[:, 1]] - pm.vertices[E2[:, 0]], axis=1))
    nv = normal_angles(unit_normals(pm.vertices, pm.faces), pm.table.pairs)
    assert np.array_equal(nv, ref.normal_angles(pm.vertices, pm.faces, pairs2))
    # the quality record from the shared topology is the one recomputed from scratch
    assert mesh_quality(pm) == mesh_quality(pm.to_trimesh())
    # and so is the one measured during the preparation, on the coordinate rows it hands on
    # (to the curvature too): those of the vertices kept
    pq = loading.prepare(V, F, {"kind": "arrays"}, with_quality=True)
    assert np.array_equal(pq.rows, pm.vertices.T) and pq.rows.flags.c_contiguous
    assert pq.quality == mesh_quality(pm.to_trimesh())


def test_distribution_summary_is_the_percentile_of_the_values():
    x = np.random.default_rng(3).lognormal(size=10001)
    x[::97] = np.nan
    before = x.copy()
    assert summary(x) == ref.summary(x)
    assert np.array_equal(x, before, equal_nan=True)   # the caller's array is not reordered


def test_collisions_of_the_weld_hash_fall_back_to_the_exact_grouping(monkeypatch):
    V, F = MESHES["scrambled"]
    soup = V[F].reshape(-1, 3)
    expect = ref.weld(soup)
    from hullprod_wb.mesh import weld

    def four_values(words):  # four hash values: nearly every corner collides
        return words[0] & np.uint64(3)
    monkeypatch.setattr(weld, "row_hashes", four_values)
    monkeypatch.setattr(weld, "hash_slots", lambda words, bits: four_values(words).astype(np.intp))
    got = loading.weld_exact(soup)
    assert np.array_equal(got[0], expect[0]) and np.array_equal(got[1], expect[1])


def _ply_header_only(path, n, m):
    with open(path, "wb") as fh:
        fh.write(("ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty float x\n"
                  "property float y\nproperty float z\nelement face %d\n"
                  "property list uchar int vertex_indices\nend_header\n" % (n, m)).encode())
        fh.write(b"\0" * 64)


def test_memory_estimate_from_the_header(tmp_path):
    p = str(tmp_path / "big.ply")
    _ply_header_only(p, 10_000_000, 20_000_000)
    need, n, m = memory.estimated_bytes(p, "ply")
    assert (n, m) == (10_000_000, 20_000_000)
    assert need > memory.BYTES_PER_VERTEX * n + memory.BYTES_PER_FACE * m
    q = str(tmp_path / "small.ply")
    _ply_header_only(q, 1000, 2000)
    assert memory.estimated_bytes(q, "ply")[0] - memory.BASE < (need - memory.BASE) / 1000


def test_too_large_mesh_refused_at_once_with_exit_2(tmp_path):
    # a file as long as its header declares (sparse: 12-byte vertices, 13-byte faces), so
    # that its structure is whole and the memory estimate decides
    full = str(tmp_path / "full.ply")
    _ply_header_only(full, 10_000_000, 20_000_000)
    with open(full, "r+b") as fh:
        header = fh.read().index(b"end_header\n") + len(b"end_header\n")
        fh.truncate(header + 10_000_000 * 12 + 20_000_000 * 13)
    env = dict(os.environ, HULLPROD_MEMORY_BYTES=str(4 * 2 ** 30))
    proc = subprocess.run([os.path.join(ROOT, "hullprod"), "analyze", full, "--json"], capture_output=True,
                          text=True, env=env, timeout=120)
    assert proc.returncode == 2 and proc.stdout == ""
    line = proc.stderr.strip().splitlines()[-1]
    assert "10000000 vertices" in line and "GB of memory" in line and "4.3 GB are available" in line
    # the header alone: refused as truncated, before anything is estimated or read
    p = str(tmp_path / "big.ply")
    _ply_header_only(p, 10_000_000, 20_000_000)
    proc = subprocess.run([os.path.join(ROOT, "hullprod"), "analyze", p, "--json"], capture_output=True,
                          text=True, env=env, timeout=120)
    assert proc.returncode == 2 and "truncated" in proc.stderr.strip().splitlines()[-1]
    # with the memory there, the truncated file is a damaged file: exit 2 too
    env["HULLPROD_MEMORY_BYTES"] = str(64 * 2 ** 30)
    proc = subprocess.run([os.path.join(ROOT, "hullprod"), "analyze", p, "--json"], capture_output=True,
                          text=True, env=env, timeout=120)
    assert proc.returncode == 2 and "GB of memory" not in proc.stderr


def test_truncated_binary_files_are_input_errors(tmp_path):
    V, F = MESHES["torus"]
    for ext in ("stl", "ply"):
        path = str(tmp_path / ("m." + ext))
        trimesh.Trimesh(V, F, process=False).export(path)
        data = open(path, "rb").read()
        with open(path, "wb") as fh:
            fh.write(data[: len(data) - 37])
        with pytest.raises(InputError):
            loading.load_mesh(path)


def test_progress_names_every_phase(tmp_path):
    V, F = MESHES["flipped"]
    path = str(tmp_path / "m.stl")
    trimesh.Trimesh(V, F, process=False).export(path)
    seen = []
    assess_mesh(path, progress=lambda f, msg: seen.append((f, msg)))
    words = ["reading", "welding", "triangle measures", "edges", "orientation", "quality", "curvature",
             "signature", "done"]
    text = [msg for _, msg in seen]
    at = [next(i for i, t in enumerate(text) if w in t) for w in words]
    assert at == sorted(at)
    fractions = [f for f, _ in seen]
    assert fractions == sorted(fractions) and fractions[-1] == 1.0


def test_mesh_json_names_no_freecad_version_unless_loaded(tmp_path):
    V, F = MESHES["torus"]
    path = str(tmp_path / "m.ply")
    trimesh.Trimesh(V, F, process=False).export(path)
    code = ("import json, sys; from hullprod_wb.mesh.backend import assess_mesh; "
            "d = json.loads(assess_mesh(sys.argv[1]).to_json()); "
            "print(json.dumps([d['software'], 'FreeCAD' in sys.modules]))")
    out = subprocess.run([sys.executable, "-c", code, path], capture_output=True, text=True, cwd=ROOT,
                         env=dict(os.environ, PYTHONPATH=ROOT), timeout=120)
    software, loaded = json.loads(out.stdout)
    assert not loaded and software["FreeCAD"] is None and software["numpy"] == np.__version__


def test_frame_u_is_the_first_least_aligned_axis_made_tangent():
    """u of the vertex frames: the coordinate axis of least |n_i| (the first of equal ones,
    as np.argmin picks it) made orthogonal to n, bit for bit; ties and signs included."""
    from hullprod_wb.mesh.curvature import _dot, frame_u
    rng = np.random.default_rng(8)
    N = rng.normal(size=(3, 3000))
    N[:, :500] = np.round(N[:, :500])                      # many equal components
    N[2, :500][~np.any(N[:, :500], axis=0)] = 1.0          # (no zero normal)
    N[:, 500:600] = 1.0
    N[2, 600:700] = -N[1, 600:700]
    N[:, 700] = (0.0, 0.0, 1.0)
    N /= np.sqrt(_dot(N, N))
    k = np.argmin(np.abs(N), axis=0)
    u = np.zeros_like(N)
    u[k, np.arange(N.shape[1])] = 1.0
    u -= N * _dot(u, N)
    u /= np.sqrt(_dot(u, u))
    assert np.all(np.isfinite(N)) and np.array_equal(frame_u(N, np.empty_like(N)), u)
