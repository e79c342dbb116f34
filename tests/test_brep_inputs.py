"""Bad BRep input gives a clear InputError (exit 2 on the command line), and provenance."""
import os
import subprocess

import pytest

from conftest import ROOT, needs_freecad, shared_hull

from hullprod_wb.core.errors import InputError

pytestmark = needs_freecad


def run_cli(*args):
    return subprocess.run([os.path.join(ROOT, "hullprod")] + list(args), capture_output=True, text=True,
                          timeout=300)


def test_missing_file(tmp_path):
    from hullprod_wb.brep.reading.loading import load_brep
    with pytest.raises(InputError, match="not found"):
        load_brep(str(tmp_path / "nope.igs"))


def test_corrupt_iges_is_rejected(tmp_path):
    from hullprod_wb.brep.reading.loading import load_brep
    p = tmp_path / "corrupt.igs"
    p.write_text("this is not an IGES file\n" * 5)
    with pytest.raises(InputError, match="(?i)iges"):
        load_brep(str(p))


def test_empty_step_is_rejected(tmp_path):
    from hullprod_wb.brep.reading.loading import load_brep
    p = tmp_path / "empty.step"
    p.write_text("")
    with pytest.raises(InputError, match="empty"):
        load_brep(str(p))


def test_shape_without_faces(tmp_path):
    from hullprod_wb.freecad_env import import_freecad
    FreeCAD = import_freecad()
    import Part
    from hullprod_wb.brep.reading.loading import load_brep
    p = tmp_path / "wire.brep"
    Part.makeLine(FreeCAD.Vector(0, 0, 0), FreeCAD.Vector(1, 0, 0)).exportBrep(str(p))
    with pytest.raises(InputError, match="no faces"):
        load_brep(str(p))
    with pytest.raises(InputError, match="null"):
        load_brep(Part.Shape())


def test_face_selection_out_of_range():
    from hullprod_wb.brep.reading.loading import load_brep
    from hullprod_wb.freecad_env import import_freecad
    import_freecad()
    import Part
    with pytest.raises(InputError, match="out of range"):
        load_brep(Part.makeBox(1, 1, 1), faces=[7])
    b = load_brep(Part.makeBox(1, 1, 1), faces=[2, 1])
    assert [n for n, _ in b.faces] == [1, 2]


def test_source_shape_is_not_modified():
    from hullprod_wb.brep.reading.loading import load_brep
    from hullprod_wb.freecad_env import import_freecad
    import_freecad()
    import Part
    box = Part.makeBox(1, 2, 3)
    before = box.exportBrepToString()
    b = load_brep(box)
    b.shape.translate(Part.Vertex(1, 1, 1).Point)
    assert box.exportBrepToString() == before


def test_declared_units_of_shared_hulls():
    from hullprod_wb.brep.reading.loading import load_brep
    b = load_brep(shared_hull("brep/dtmb5415_half_overture.igs"))
    assert b.units["source_unit"] == "m" and b.units["working_unit"] == "mm"
    assert b.info["face_count"] == 3


def test_provenance_counts_creases_and_side():
    from hullprod_wb.brep.reading.loading import load_brep
    from hullprod_wb.brep.reading.provenance import shape_provenance
    from hullprod_wb.freecad_env import import_freecad
    import_freecad()
    import Part
    box = Part.makeBox(2, 1, 1)
    b = load_brep(box)
    prov = shape_provenance(b.shape, b.faces)
    # A box: 12 edges, each shared by two faces at 90 degrees.
    assert prov["edges"]["free_edges"] == 0
    assert prov["edges"]["shared_edge_sides"] == 24
    assert prov["edges"]["c0_crease_length"] == pytest.approx(4 * 2 + 8 * 1)
    assert prov["hull_side"].startswith("starboard")
    assert prov["surface_types"] == {"Plane": 6}


def test_cli_bad_brep_inputs_exit_2(tmp_path):
    p = tmp_path / "corrupt.iges"
    p.write_text("garbage\n")
    for args in (["analyze", str(tmp_path / "missing.step")], ["analyze", str(p)],
                 ["analyze", str(tmp_path / "x.xyz")]):
        if args[1].endswith(".xyz"):
            (tmp_path / "x.xyz").write_text("1 2 3\n")
        r = run_cli(*args)
        assert r.returncode == 2, (args, r.stdout, r.stderr)
        # progress lines may precede it; the reason is one line, the last
        errors = [line for line in r.stderr.splitlines() if line.startswith("hullprod: error:")]
        assert len(errors) == 1 and r.stderr.strip().splitlines()[-1] == errors[0]


def test_automatic_lref_independent_of_fields_and_cached_tessellations():
    """The automatic L_ref comes from the nodes of one fixed tessellation: the same with and
    without display fields, whatever display_deflection says and whatever triangulation the
    source shape already carries (e.g. from the 3D view: the assessment works on a copy);
    a torus (span 2 (R + r) = 8 along its principal axes) gives 8 to the tessellation's
    accuracy."""
    from hullprod_wb.examples.analytic_shapes import torus_shape
    from hullprod_wb.brep.backend import assess_brep
    a = assess_brep(torus_shape(), with_fields=False, cross_checks=False, audit=False)
    b = assess_brep(torus_shape(), with_fields=True, cross_checks=False, audit=False,
                    display_deflection=0.05)
    la = a.reference_length.value
    assert a.reference_length.mode == "automatic"
    assert abs(la - 8.0) < 0.05
    assert b.reference_length.value == la
    assert a.fields is None and b.fields is not None
    assert a.vector == b.vector
    from hullprod_wb.examples.builtin import half_wigley_shape
    hull = half_wigley_shape()
    before = assess_brep(hull, with_fields=False, cross_checks=False, audit=False)
    size = hull.BoundBox.DiagonalLength
    coarse = len(hull.copy().tessellate(2e-2 * size)[0])
    assert len(hull.tessellate(5e-3 * size)[0]) > 10 * coarse  # a fine triangulation cached on the source
    after = assess_brep(hull, with_fields=False, cross_checks=False, audit=False)
    assert after.reference_length.value == before.reference_length.value
    assert after.vector == before.vector


def test_command_output_complete_after_its_fast_exit(tmp_path):
    """The command leaves without the interpreter's teardown (cli.exit_now): what it printed
    and wrote is complete, and the exit status is kept, for a BRep and a mesh."""
    import json
    from hullprod_wb.examples.builtin import half_wigley_shape
    step = str(tmp_path / "wigley.step")
    half_wigley_shape().exportStep(step)
    p = run_cli("analyze", step, "--json", "--quiet", "--lref", "1")
    assert p.returncode == 0, p.stderr
    doc = json.loads(p.stdout)
    assert doc["signature"]["I_D"] > 0
    out = tmp_path / "out"
    p = run_cli("analyze", step, "--quiet", "--lref", "1", "--out", str(out))
    assert p.returncode == 0, p.stderr
    assert json.loads((out / "signature.json").read_text())["signature"] == doc["signature"]
    assert (out / "fields.vtp").read_text().rstrip().endswith("</VTKFile>")
    p = run_cli("analyze", step, "--lref", "0")
    assert p.returncode == 2 and "L_ref" in p.stderr
    from hullprod_wb.examples.analytic_meshes import half_wigley_mesh
    stl = str(tmp_path / "wigley.stl")
    import trimesh
    trimesh.Trimesh(*half_wigley_mesh(40, 10), process=False).export(stl)
    mesh_out = tmp_path / "mesh_out"
    p = run_cli("analyze", stl, "--quiet", "--lref", "1", "--out", str(mesh_out))
    assert p.returncode == 0, p.stderr
    assert json.loads((mesh_out / "signature.json").read_text())["signature"]["I_D"] > 0
    assert (mesh_out / "fields.vtp").read_text().rstrip().endswith("</VTKFile>")
    assert "I_D" in p.stdout
