"""Damaged and unusual input files: structural checks before the reader, faces that cannot be
evaluated, FreeCAD documents as input, the batch's per-case time limit."""
import hashlib
import json
import os
import struct
import subprocess
import sys

import numpy as np
import pytest

from conftest import ROOT, needs_freecad, shared_hull

from hullprod_wb.core.errors import InputError
from hullprod_wb.core.file_checks import check_file, fewer_faces
from hullprod_wb.core.validity import MetricValidity, Status, qualify_all

CUTS = [0.10, 0.17, 0.25, 0.33, 0.5, 0.6, 0.75, 0.8, 0.9, 0.95, 0.99]


def run_cli(*args):
    return subprocess.run([os.path.join(ROOT, "hullprod")] + list(args), capture_output=True, text=True,
                          timeout=600)


@pytest.fixture(scope="module")
def brep_files(tmp_path_factory):
    """A two-face B-spline shell written as IGES, STEP and .brep (the fuzz harness's base
    files, made in a child process)."""
    from fuzz_cases import GENERATE_BREP
    d = tmp_path_factory.mktemp("hostile")
    subprocess.run([sys.executable, "-c", GENERATE_BREP, str(d)], check=True, capture_output=True, timeout=120)
    return {"iges": str(d / "base.igs"), "step": str(d / "base.step"), "brep": str(d / "base.brep")}


@pytest.fixture(scope="module")
def mesh_files(tmp_path_factory):
    """A small open triangle mesh as binary STL, binary PLY and ASCII PLY."""
    import trimesh
    n = 8
    x, y = np.meshgrid(np.linspace(0, 10, n), np.linspace(0, 3, n), indexing="ij")
    v = np.column_stack([x.ravel(), y.ravel(), (0.05 * (x - 5) ** 2).ravel()])
    i = np.arange(n * n).reshape(n, n)
    a, b, c, e = i[:-1, :-1].ravel(), i[1:, :-1].ravel(), i[1:, 1:].ravel(), i[:-1, 1:].ravel()
    mesh = trimesh.Trimesh(v, np.vstack([np.column_stack([a, b, c]), np.column_stack([a, c, e])]), process=False)
    d = tmp_path_factory.mktemp("hostile_mesh")
    out = {"stl": str(d / "m.stl"), "ply": str(d / "m.ply"), "ply_ascii": str(d / "ma.ply")}
    mesh.export(out["stl"])
    with open(out["ply"], "wb") as fh:
        fh.write(trimesh.exchange.ply.export_ply(mesh, encoding="binary"))
    with open(out["ply_ascii"], "wb") as fh:
        fh.write(trimesh.exchange.ply.export_ply(mesh, encoding="ascii"))
    return out


def cut(path, fraction, tmp_path):
    data = open(path, "rb").read()
    p = tmp_path / ("cut%03d_%s" % (round(1000 * fraction), os.path.basename(path)))
    p.write_bytes(data[:int(len(data) * fraction)])
    return str(p)


@needs_freecad
@pytest.mark.parametrize("fmt", ["iges", "step", "brep"])
def test_brep_files_cut_anywhere_are_truncated(brep_files, fmt, tmp_path):
    path = brep_files[fmt]
    assert check_file(path, fmt)["declared_faces"] == 2
    for f in CUTS:
        with pytest.raises(InputError, match="truncated"):
            check_file(cut(path, f, tmp_path), fmt)


@pytest.mark.parametrize("fmt", ["stl", "ply", "ply_ascii"])
def test_mesh_files_cut_anywhere_are_truncated(mesh_files, fmt, tmp_path):
    path = mesh_files[fmt]
    kind = fmt.split("_")[0]
    check_file(path, kind)
    for f in CUTS:
        with pytest.raises(InputError, match="truncated"):
            check_file(cut(path, f, tmp_path), kind)


@pytest.mark.parametrize("count_type,order", [("uchar", "<"), ("ushort", ">"), ("uint", "<")])
def test_binary_ply_face_lists_of_mixed_lengths(tmp_path, count_type, order):
    """Runs of triangles, quads and pentagons in a binary PLY: the whole file passes, and the
    reason of a cut or an overstated face count names the face the file ends in."""
    import struct
    cf = {"uchar": "B", "ushort": "H", "uint": "I"}[count_type]
    counts = [3] * 700 + [4] * 5 + [3, 4] * 50 + [5] + [3] * 300
    fmt = "binary_little_endian" if order == "<" else "binary_big_endian"

    def ply(declared, faces):
        head = ("ply\nformat %s 1.0\nelement vertex 5\nproperty float x\nproperty float y\n"
                "property float z\nelement face %d\nproperty list %s int vertex_indices\nend_header\n"
                % (fmt, declared, count_type)).encode()
        body = struct.pack(order + "15f", *range(15))
        body += b"".join(struct.pack(order + cf + "%di" % c, c, *range(c)) for c in faces)
        p = tmp_path / ("f%d_%d.ply" % (declared, len(faces)))
        p.write_bytes(head + body)
        return str(p)

    assert check_file(ply(len(counts), counts), "ply")["declared_elements"] == {"vertex": 5, "face": len(counts)}
    with pytest.raises(InputError, match=r"ends in face %d:" % (len(counts) + 1)):
        check_file(ply(len(counts) + 1, counts), "ply")
    with pytest.raises(InputError, match=r"ends in face 751:"):
        check_file(ply(len(counts), counts[:750]), "ply")
    with pytest.raises(InputError, match="ends in its last face"):
        data = open(ply(len(counts), counts), "rb").read()
        cut = tmp_path / "cut.ply"
        cut.write_bytes(data[:-2])
        check_file(str(cut), "ply")


@needs_freecad
def test_iges_reasons_name_what_is_missing(brep_files, tmp_path):
    lines = open(brep_files["iges"], "rb").read().split(b"\n")
    p_lines = [k for k, line in enumerate(lines) if line[72:73] == b"P"]
    # cut inside the parameter section: the reason counts the parameter lines present
    p = tmp_path / "cut.igs"
    p.write_bytes(b"\n".join(lines[:p_lines[len(p_lines) // 2]]))
    with pytest.raises(InputError, match=r"truncated: the IGES Terminate section is missing.*\b%d of %d parameter "
                                         r"lines present" % (len(p_lines) // 2, len(p_lines))):
        check_file(str(p), "iges")
    # a parameter line deleted: its numbering says so
    p = tmp_path / "deleted.igs"
    p.write_bytes(b"\n".join(lines[:p_lines[3]] + lines[p_lines[3] + 1:]))
    with pytest.raises(InputError, match="numbered .* expected"):
        check_file(str(p), "iges")
    # a directory entry pointing past the parameter section
    d = next(k for k, line in enumerate(lines) if line[72:73] == b"D")
    bad = lines[d][:8] + b"%8d" % 99999 + lines[d][16:]
    p = tmp_path / "pointer.igs"
    p.write_bytes(b"\n".join(lines[:d] + [bad] + lines[d + 1:]))
    with pytest.raises(InputError, match="points to parameter lines 99999"):
        check_file(str(p), "iges")
    # and through the command: exit 2 with one line
    r = run_cli("analyze", cut(brep_files["iges"], 0.6, tmp_path), "--json")
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "truncated" in r.stderr


def test_binary_stl_count_against_size(mesh_files, tmp_path):
    data = bytearray(open(mesh_files["stl"], "rb").read())
    n = struct.unpack("<I", data[80:84])[0]
    data[80:84] = struct.pack("<I", n + 3)
    p = tmp_path / "more.stl"
    p.write_bytes(bytes(data))
    with pytest.raises(InputError, match="declares %d triangles" % (n + 3)):
        check_file(str(p), "stl")


@pytest.mark.parametrize("padding", [b"", b"\n", b" \r\n" * 3000 + b"\x00" * 5000 + b"\x1a"])
def test_ascii_stl_end_read_from_the_tail(tmp_path, padding):
    """The endsolid line is found behind any run of trailing blanks, NUL or ^Z bytes (the
    file is mapped and its tail read a few kB at a time); a file without it is truncated."""
    body = b"solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n" \
           b"endloop\nendfacet\n"
    whole, cut = tmp_path / "whole.stl", tmp_path / "cut.stl"
    whole.write_bytes(body + b"endsolid a" + padding)
    cut.write_bytes(body + b"facet normal 0 0 1" + padding)
    assert check_file(str(whole), "stl") == {}
    with pytest.raises(InputError, match="does not end with endsolid .last line 'facet normal 0 0 1'"):
        check_file(str(cut), "stl")


def test_fewer_faces_than_declared_is_a_caution():
    validity = {m: MetricValidity(Status.VALID, 1.0, "", "converged") for m in ("I_D", "a_flat")}
    assert fewer_faces({"declared": {"declared_faces": 3}, "face_count": 3}) is None
    q = fewer_faces({"declared": {"declared_faces": 3, "declared_faces_rule": "r"}, "face_count": 1})
    qualify_all(validity, q)
    for rec in validity.values():
        assert rec.status == Status.CAUTION and rec.code == "fewer_faces_than_declared"
        assert "1 faces of the 3" in rec.reason and rec.evidence["faces_read"] == 1


def _two_faces():
    from hullprod_wb.freecad_env import import_freecad
    FreeCAD = import_freecad()
    import Part
    faces = []
    for k in range(2):
        pts = [[FreeCAD.Vector(1.0 * i + 4.0 * k, 0.3 * j, 0.04 * (i - 1.5) ** 2 - 0.025 * (j - 1.5) ** 2)
                for j in range(4)] for i in range(5)]
        s = Part.BSplineSurface()
        s.interpolate(pts)
        faces.append(s.toShape())
    return Part.makeShell(faces)


@needs_freecad
def test_a_face_that_raises_is_not_evaluated(monkeypatch):
    from hullprod_wb.brep import backend
    shape = _two_faces()
    whole = backend.assess_brep(shape, lref=10.0, with_fields=False, jobs=1)
    real = backend.assess_face

    def failing(number, face, *a, **kw):
        if number == 2:
            raise RuntimeError("no p-curve for this edge")
        return real(number, face, *a, **kw)

    monkeypatch.setattr(backend, "assess_face", failing)
    res = backend.assess_brep(shape, lref=10.0, with_fields=False, jobs=1)
    row = next(r for r in res.provenance["faces"] if r["face"] == 2)
    assert row["status"] == "NOT EVALUATED" and "no p-curve" in row["reason"]
    # its area from our own quadrature: the two faces are congruent, so half of the whole
    assert row["area_estimate"] == pytest.approx(0.5 * whole.integrals.represented_area, rel=1e-6)
    for m, rec in res.validity.items():
        assert rec.status == Status.CAUTION and rec.code == "faces_not_evaluated", m
        assert "face(s) 2 NOT EVALUATED (50 % of the area)" in rec.reason
    assert res.integrals.represented_area == pytest.approx(0.5 * whole.integrals.represented_area, rel=1e-9)

    monkeypatch.setattr(backend, "assess_face", lambda *a, **kw: (_ for _ in ()).throw(ValueError("bad")))
    with pytest.raises(InputError, match="no face could be evaluated: Face1: ValueError: bad; Face2"):
        backend.assess_brep(shape, lref=10.0, with_fields=False, jobs=1)


@needs_freecad
def test_occ_area_failures_do_not_end_the_provenance():
    from hullprod_wb.brep.reading.loading import load_brep
    from hullprod_wb.brep.reading.provenance import occ_face_area, shape_provenance
    inp = load_brep(shared_hull("brep/wigley_full_freecadship.brep"))
    failed = [n for n, f in inp.faces if occ_face_area(f) is None]
    assert failed  # OpenCascade's BRepGProp raises on some of its faces
    prov = shape_provenance(inp.shape, inp.faces)
    assert prov["occ_area_failed_faces"] == failed and prov["occ_area"] > 0


@needs_freecad
def test_face_without_domain_extent_has_zero_area():
    from hullprod_wb.brep.face_setup import FaceSetup
    from hullprod_wb.brep.geometry.trimmed_domain import EmptyDomain
    from hullprod_wb.brep.validity.left_out import left_out_face
    from hullprod_wb.brep.reading.loading import load_brep
    inp = load_brep(shared_hull("brep/kcs_full_closed_ohp.iges"))
    empty = []
    for n, f in inp.faces:
        try:
            FaceSetup(f)
        except EmptyDomain as exc:
            empty.append(left_out_face(n, f, exc))
    assert empty and all(e.area_estimate == 0.0 for e in empty)
    assert all(occ < 1e-6 for occ in (inp.faces[e.number - 1][1].Area for e in empty))


@needs_freecad
def test_fcstd_document_input(tmp_path):
    path = shared_hull("fcstd/series60_freecadship.FCStd")
    before = (hashlib.sha256(open(path, "rb").read()).hexdigest(), os.path.getmtime(path))
    r = run_cli("analyze", path, "--object", "Ship", "--json", "--no-fields", "--max-depth", "3")
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    inp = doc["input"]
    assert inp["path"] == os.path.abspath(path) and inp["sha256"] == before[0]
    assert (inp["object"], inp["label"], inp["format"]) == ("Ship", "Ship", "fcstd")
    assert doc["signature"]["I_D"] > 0
    assert (hashlib.sha256(open(path, "rb").read()).hexdigest(), os.path.getmtime(path)) == before
    r = run_cli("analyze", path, "--object", "NoSuchThing", "--json")
    assert r.returncode == 2 and "Ship" in r.stderr and r.stderr.count("\n") == 1


@needs_freecad
def test_fcstd_with_several_objects_lists_them(tmp_path):
    from hullprod_wb.api import assess
    from hullprod_wb.freecad_env import import_freecad
    FreeCAD = import_freecad()
    import Part
    doc = FreeCAD.newDocument("hostile_two")
    try:
        for name in ("HullA", "HullB"):
            doc.addObject("Part::Feature", name).Shape = _two_faces()
        doc.recompute()
        path = str(tmp_path / "two.FCStd")
        doc.saveAs(path)
    finally:
        FreeCAD.closeDocument(doc.Name)
    with pytest.raises(InputError, match="2 shape-bearing top-level objects: HullA .*HullB"):
        assess(path)
    res = assess(path, object_name="HullB", lref=10.0, with_fields=False, max_depth=3)
    assert res.input["object"] == "HullB" and res.input["format"] == "fcstd"
    assert Part  # imported after FreeCAD, as documents need


def test_batch_case_timeout_gives_an_error_row(tmp_path):
    from hullprod_wb.batch.api import split_options
    from hullprod_wb.batch.cases import expand_cases, settings_hash
    from hullprod_wb.batch.worker import run_case
    from hullprod_wb.examples.analytic_meshes import half_wigley_mesh
    import trimesh
    v, f = half_wigley_mesh(20, 6)[:2]
    p = tmp_path / "w.stl"
    trimesh.Trimesh(v, f, process=False).export(str(p))
    settings = split_options({})
    plain = settings_hash(settings)
    settings["case_timeout"] = 1e-3
    assert settings_hash(settings) == plain  # the limit is not part of what is computed
    case = expand_cases([str(p)])[0]
    rec = run_case(case, settings, plain)
    assert rec["status"] == "error" and rec["error"]["type"] == "CaseTimeout"
    assert rec["row"]["case_timeout_s"] == 1e-3 and "--case-timeout" in rec["row"]["error"]


def test_numbers_of_1e100_or_more_are_refused_before_the_reader():
    # OpenCascade takes 2e100 as infinite, and its readers can stall on such poles
    from hullprod_wb.core import file_checks
    from hullprod_wb.core.errors import InputError
    step = (b"ISO-10303-21;\nHEADER;\nENDSEC;\nDATA;\n#1=CARTESIAN_POINT('',(1.E+99,0.,0.));\nENDSEC;\n"
            b"END-ISO-10303-21;\n")
    file_checks.check_step("a.step", step)
    with pytest.raises(InputError, match="a number of 1e100 or more \\(line 5\\)"):
        file_checks.check_step("a.step", step.replace(b"1.E+99", b"1.E+150"))
