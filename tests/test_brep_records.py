"""A BRep file assessed from the plain records of a reading child process
(brep.reading.record_reader, brep.recorded_shape): the same numbers, to the bit, as reading it in
this process; faces the records do not describe sent as OpenCascade's data; a child that
dies reported; errors with the same messages; a reading side that never loads numpy."""
import math
import os
import subprocess
import sys

import pytest

from conftest import made_in_a_child, needs_freecad, shared_hull
from hullprod_wb.core import processes
from hullprod_wb.core.errors import InputError

pytestmark = [needs_freecad,
              pytest.mark.skipif(not processes.fork_is_safe(), reason="forking is not available here")]

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
_PARENT = os.getpid()


def _part():
    from hullprod_wb.freecad_env import import_freecad
    import_freecad()
    import Part
    from FreeCAD import Vector
    return Part, Vector


def wavy_bspline_face(nu=6, nv=5):
    Part, V = _part()
    ku = [i / nu for i in range(nu + 1)]
    kv = [j / nv for j in range(nv + 1)]
    poles = [[V(4.0 * i / (nu + 2), 3.0 * j / (nv + 2), 0.2 * math.sin(0.9 * i) * math.cos(0.7 * j))
              for j in range(nv + 3)] for i in range(nu + 3)]
    s = Part.BSplineSurface()
    s.buildFromPolesMultsKnots(poles, [4] + [1] * (nu - 1) + [4], [4] + [1] * (nv - 1) + [4], ku, kv,
                               False, False, 3, 3)
    return s.toShape()


def trimmed_bspline_face():
    """A curved B-spline face with a circular hole (B-spline p-curves)."""
    Part, V = _part()
    poles = [[V(3 * i, 2 * j, 0.3 * math.sin(i + 2 * j)) for j in range(4)] for i in range(4)]
    s = Part.BSplineSurface()
    s.buildFromPolesMultsKnots(poles, [4, 4], [4, 4], [0, 1], [0, 1], False, False, 3, 3)
    return s.toShape().cut(Part.makeCylinder(1.5, 10, V(4.2, 3.1, -5))).Faces[0]


def both_ways(path, **kw):
    """(assessed from the records of a reading child, assessed from the file read here)."""
    from hullprod_wb.brep.backend import assess_brep
    from hullprod_wb.brep.reading.record_reader import ReadInChild
    with_fields = kw.get("with_fields", True)
    recorded = assess_brep(ReadInChild(path, kw.get("faces"), with_fields), **kw)
    here = assess_brep(path, **kw)
    return recorded, here


def same_records(a, b):
    """The two assessments agree in every number they report (timings and seconds aside)."""
    assert a.vector == b.vector
    assert a.reference_length.to_dict() == b.reference_length.to_dict()
    assert {m: (v.status, v.value) for m, v in a.validity.items()} == \
        {m: (v.status, v.value) for m, v in b.validity.items()}
    strip = lambda rows: [{k: v for k, v in r.items() if k != "seconds"} for r in rows]
    pa = {k: v for k, v in a.provenance.items() if k not in ("reading", "cross_checks", "quadrature")}
    pb = {k: v for k, v in b.provenance.items() if k not in ("reading", "cross_checks", "quadrature")}
    assert pa == pb
    assert strip(a.provenance["cross_checks"]) == strip(b.provenance["cross_checks"])
    for qa, qb in zip(a.provenance["quadrature"], b.provenance["quadrature"]):
        assert qa["values"] == qb["values"] and qa["errors"] == qb["errors"]
    assert {k: v for k, v in a.options.items()} == {k: v for k, v in b.options.items()}
    assert a.input == b.input


def test_records_give_the_values_of_the_file_read_here(tmp_path):
    Part, V = _part()
    shapes = {"wavy.step": wavy_bspline_face(), "trimmed.brep": trimmed_bspline_face(),
              "two.step": Part.Compound([wavy_bspline_face(4, 3), trimmed_bspline_face()])}
    for name, shape in shapes.items():
        path = str(tmp_path / name)
        (shape.exportBrep if name.endswith(".brep") else shape.exportStep)(path)
        recorded, here = both_ways(path, lref=4.0, jobs=1)
        assert recorded.provenance["reading"].startswith("OpenCascade in a separate process")
        assert here.provenance["reading"] == "OpenCascade in this process"
        same_records(recorded, here)
        # the display fields are the same samples
        fa, fb = recorded.fields, here.fields
        for k in ("points", "triangles", "K", "H", "valid"):
            assert (getattr(fa, k) == getattr(fb, k)).all(), (name, k)
    # several faces in worker processes, and a face selection
    path = str(tmp_path / "two.step")
    recorded, here = both_ways(path, lref=4.0, jobs=2, with_fields=False)
    same_records(recorded, here)
    recorded, here = both_ways(path, lref=4.0, faces=[2], with_fields=False)
    assert recorded.input["faces_used"] == [2]
    same_records(recorded, here)


def test_bezier_example_and_periodic_bspline_faces_from_records(tmp_path):
    from hullprod_wb.examples.builtin import write_builtin_example
    Part, V = _part()
    path, lref, _ = write_builtin_example(str(tmp_path))  # the README example: a Bezier face
    recorded, here = both_ways(path, lref=lref, with_fields=False)
    assert recorded.provenance["reading"].startswith("OpenCascade in a separate process")
    same_records(recorded, here)
    # a B-spline cylinder and sphere, periodic in u, with a seam (both of its p-curves)
    for name, shape in (("cyl.brep", Part.makeCylinder(1, 2).Faces[0].toNurbs()),
                        ("sphere.brep", Part.makeSphere(1).Faces[0].toNurbs())):
        assert shape.Faces[0].Surface.isUPeriodic()
        p = str(tmp_path / name)
        shape.exportBrep(p)
        recorded, here = both_ways(p, lref=2.0, with_fields=False)
        assert recorded.provenance["reading"].startswith("OpenCascade in a separate process")
        same_records(recorded, here)


def test_shared_hulls_from_records_are_the_same():
    for name, kw in (("brep/wigley_half_wavebem.iges", {}),
                     ("brep/dtmb5415_half_overture.igs", {"lref": 5720.0, "faces": [1, 2]}),
                     # a trim-loop gap closed at a vertex, from the records' edge vertices
                     ("brep/kvlcc2_half_overture.igs", {"faces": [10]})):
        recorded, here = both_ways(shared_hull(name), with_fields=False, **kw)
        assert recorded.provenance["reading"].startswith("OpenCascade in a separate process")
        same_records(recorded, here)
        if "kvlcc2" in name:
            assert recorded.provenance["faces"][0]["repairs"][0].startswith("gap closed at vertex")


def test_faces_of_other_types_travel_as_opencascade_data(tmp_path):
    """Planes, cylinders and faces with p-curves the records do not describe are sent as
    OpenCascade's binary BRep data and rebuilt where they are integrated: the values of the
    file read here, whatever the processes."""
    from hullprod_wb.brep.backend import assess_brep
    from hullprod_wb.brep.reading.record_reader import ReadInChild
    from hullprod_wb.brep.recorded_shape import RecordedShape
    Part, V = _part()
    box, mixed = str(tmp_path / "box.step"), str(tmp_path / "mixed.step")
    Part.makeBox(1, 2, 3).exportStep(box)  # planar faces
    Part.Compound([wavy_bspline_face(4, 3), Part.makeCylinder(0.5, 1.0, V(0, 0, 1)).Faces[0],
                   Part.makePlane(1.0, 1.0, V(0, 0, -2))]).exportStep(mixed)
    shape = RecordedShape(ReadInChild(mixed, None, False))
    kinds = [(f.surface_type, f.as_data) for _, f in shape.faces]
    assert kinds == [("BSplineSurface", False), ("Cylinder", True), ("Plane", True)]
    assert "Cylinder surface" in shape.faces[1][1].rec.reason
    rebuilt = shape.faces[1][1].part_face()
    assert type(rebuilt.Surface).__name__ == "Cylinder" and rebuilt.Area == pytest.approx(math.pi)
    shape.close()
    r = assess_brep(ReadInChild(box, None, False), with_fields=False, lref=3.0)
    assert r.provenance["reading"].startswith("OpenCascade in a separate process")
    assert r.signature["I_D"] == 0.0 and r.integrals.represented_area == pytest.approx(22.0, rel=1e-12)
    for kw in ({"jobs": 1}, {"jobs": 2, "with_fields": False}):
        recorded, here = both_ways(mixed, lref=4.0, **kw)
        same_records(recorded, here)


def test_errors_of_the_reading_process_are_raised_here(tmp_path):
    from hullprod_wb.brep.backend import assess_brep
    from hullprod_wb.brep.reading.record_reader import ReadInChild
    bad = tmp_path / "bad.igs"
    bad.write_text("not an IGES file\n" * 5)
    with pytest.raises(InputError) as here:
        assess_brep(str(bad), with_fields=False)
    with pytest.raises(InputError) as child:
        assess_brep(ReadInChild(str(bad), None, False), with_fields=False)
    assert str(child.value) == str(here.value)
    path = str(tmp_path / "wavy.step")
    wavy_bspline_face().exportStep(path)
    with pytest.raises(InputError, match="out of range"):
        assess_brep(ReadInChild(path, [3], False), with_fields=False)


def _dies_in_child(*args, **kw):
    if os.getpid() != _PARENT:
        os._exit(3)
    raise AssertionError("called in the parent")


@pytest.mark.clean_process  # the reading process is forked, with the stand-ins below
def test_a_reading_process_that_dies_is_reported(tmp_path, monkeypatch):
    """A reading process that ends (an exit or a signal) before its last frame raises
    ReaderDied, naming the file, what OpenCascade was doing and the likely cause; nothing
    is read here instead."""
    from hullprod_wb.brep.reading import lref_samples, loading, record_reader
    from hullprod_wb.brep.backend import assess_brep
    from hullprod_wb.core.errors import ReaderDied
    path = str(tmp_path / "wavy.step")
    wavy_bspline_face().exportStep(path)
    original = lref_samples.tessellate_faces

    def killed(*args):
        if os.getpid() != _PARENT:
            os.kill(os.getpid(), 9)  # (FreeCAD's own handler ends a crash with exit 1)
        return original(*args)
    for module, name, stand_in, what in (
            (loading, "read_shape", _dies_in_child, "OpenCascade's STEP reader ended the process (exit 3)"),
            (record_reader, "face_record", _dies_in_child,
             "OpenCascade ended the reading process while describing the faces (exit 3)"),
            (record_reader, "tessellate_faces", killed,
             "OpenCascade ended the reading process while tessellating the faces (signal 9, SIGKILL)")):
        with monkeypatch.context() as m:
            m.setattr(module, name, stand_in)
            with pytest.raises(ReaderDied) as err:
                assess_brep(record_reader.ReadInChild(path, None, False), with_fields=False, lref=4.0)
            assert str(err.value) == "%s: %s; the file is probably damaged" % (path, what)
            if name == "read_shape":  # a file loaded by the other commands (studies) too
                with pytest.raises(ReaderDied, match="STEP reader ended the process"):
                    loading.load_brep(path)


def test_the_reading_side_does_not_load_numpy(tmp_path):
    path = str(tmp_path / "wavy.step")
    wavy_bspline_face().exportStep(path)
    script = (
        "import sys\n"
        "sys.path.insert(0, %r)\n"
        "from hullprod_wb.freecad_env import import_freecad\n"
        "import_freecad()\n"
        "from hullprod_wb.brep.reading import record_reader\n"
        "from hullprod_wb.brep.reading.loading import load_brep\n"
        "frames = list(record_reader._frames(load_brep(%r), True, None, 0.0))\n"
        "assert len(frames) == 4 and frames[0][record_reader.FRAME].faces, frames[0]\n"
        "assert len(frames[2][record_reader.FRAME].display) == 1, frames[2]\n"
        "assert 'numpy' not in sys.modules, sorted(m for m in sys.modules if 'numpy' in m)[:5]\n"
        "print('ok', len(frames[0][record_reader.FRAME].faces))\n" % (ROOT, path))
    p = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr[-2000:]
    assert p.stdout.split() == ["ok", "1"]


def test_the_command_reads_brep_files_in_a_separate_process(tmp_path):
    path = str(tmp_path / "wavy.step")
    wavy_bspline_face().exportStep(path)
    import json
    p = subprocess.run([os.path.join(ROOT, "hullprod"), "analyze", path, "--lref", "4", "--json", "--quiet"],
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr[-2000:]
    doc = json.loads(p.stdout)
    assert doc["provenance"]["reading"].startswith("OpenCascade in a separate process")
    assert doc["software"]["FreeCAD"] and doc["software"]["OCC"]
    from hullprod_wb import assess
    here = assess(_part()[0].read(path), lref=4.0, with_fields=False)
    # another process, with its own BLAS threads (sums in another order): not to the bit
    assert doc["signature"]["I_D"] == pytest.approx(here.signature["I_D"], rel=1e-12)


def test_a_face_whose_domain_needs_opencascade_is_read_here(tmp_path, monkeypatch):
    from hullprod_wb.brep.backend import assess_brep
    from hullprod_wb.brep.recorded_shape import FaceRecord
    from hullprod_wb.brep.reading.record_reader import ReadInChild
    from hullprod_wb.brep.geometry.trimmed_domain import TrimmedDomain
    path = str(tmp_path / "trimmed.step")
    trimmed_bspline_face().exportStep(path)
    here = assess_brep(path, with_fields=False, lref=4.0)
    # as for a p-curve whose conversion fails its check: the face itself, read in this process
    asked, rebuilt = [], []
    part_face = FaceRecord.part_face
    monkeypatch.setattr(TrimmedDomain, "from_record",
                        classmethod(lambda cls, rec, evaluator: asked.append(rec.number)))
    monkeypatch.setattr(FaceRecord, "part_face", lambda self: rebuilt.append(self.number) or part_face(self))
    r = assess_brep(ReadInChild(path, None, False), with_fields=False, lref=4.0)
    assert asked and set(asked) == {1}  # the records could not give the domain
    assert rebuilt and set(rebuilt) == {1}  # so the face was rebuilt from OpenCascade's data
    same_records(r, here)


@pytest.mark.clean_process  # set-ups for worker processes: a process that may fork them
def test_faces_are_set_up_here_while_the_reading_process_tessellates(tmp_path, monkeypatch):
    """The records arrive before the L_ref tessellation; while it runs, this process sets the
    faces up (smallest first) for the worker processes, which take those set-ups over: the
    numbers are those of the file read here. A face whose domain needs OpenCascade is left
    to its worker."""
    from hullprod_wb.brep import backend
    from hullprod_wb.brep.face_setup import FaceSetup
    from hullprod_wb.brep.reading.record_reader import ReadInChild
    from hullprod_wb.brep.recorded_shape import RecordedShape
    from hullprod_wb.brep.geometry.trimmed_domain import TrimmedDomain
    Part, _ = _part()
    path = str(tmp_path / "two.step")
    made_in_a_child(lambda: Part.Compound([wavy_bspline_face(4, 3), trimmed_bspline_face()])).exportStep(path)

    reader = ReadInChild(path, None, False)
    first = reader.faces_frame()
    assert all(not hasattr(rec, "area") for rec in first.faces)  # OpenCascade's areas come last
    reader.lref_frame()
    assert reader.lref_ready()
    reader.close()

    made = []
    here_ = FaceSetup.here

    def counted(face, area_check=False):
        made.append(face.number)
        return here_(face, area_check)
    polls = iter([False, False, False, False])  # still tessellating for two faces' set-ups
    monkeypatch.setattr(RecordedShape, "lref_ready", lambda self: next(polls, True))
    monkeypatch.setattr(FaceSetup, "here", staticmethod(counted))
    r = backend.assess_brep(ReadInChild(path, None, False), lref=4.0, jobs=2, with_fields=False)
    assert sorted(made) == [1, 2]

    made.clear()
    polls = iter([False] * 4)
    monkeypatch.setattr(TrimmedDomain, "from_record", classmethod(lambda cls, rec, evaluator: None))
    shape = RecordedShape(ReadInChild(path, None, False))
    assert here_(shape.faces[0][1]) is None
    shape.close()
    r2 = backend.assess_brep(ReadInChild(path, None, False), lref=4.0, jobs=2, with_fields=False)
    # read here (the shape in this process) after the records' runs: its provenance starts
    # OpenCascade's threads on FreeCAD 1.x, and this process then forks no worker processes
    here = backend.assess_brep(path, lref=4.0, jobs=2, with_fields=False)
    same_records(r, here)
    same_records(r2, here)


def test_a_lone_face_prefetches_its_first_levels_while_the_reading_process_tessellates(tmp_path, monkeypatch):
    """A face assessed alone is set up while the L_ref tessellation runs, and then the field
    at the nodes of the first two quadtree levels of its patch groups is evaluated
    (cubature.NodePrefetch) until L_ref arrives; the integration takes those values over:
    the same integrals, to the bit, as the file read here."""
    from hullprod_wb.brep import backend, cubature
    from hullprod_wb.brep.reading.record_reader import ReadInChild
    from hullprod_wb.brep.recorded_shape import RecordedShape
    Part, _ = _part()
    path = str(tmp_path / "lone.step")
    wavy_bspline_face(20, 15).exportStep(path)  # 300 patches: two patch groups
    here = backend.assess_brep(path, lref=4.0, jobs=2, with_fields=False)
    steps = []
    step = cubature.NodePrefetch.step

    def counted(self):
        steps.append(len(self.values))
        return step(self)
    monkeypatch.setattr(cubature.NodePrefetch, "step", counted)
    # two groups of 150 patches: each group's patches in one step, their 600 children in
    # three (cubature.settings.PREFETCH_CELLS)
    for polls, levels in (([False] * 20, [0, 0, 1, 1, 1, 1, 1, 1]), ([False, False, False, True], [0, 0])):
        steps.clear()
        poll = iter(polls)
        monkeypatch.setattr(RecordedShape, "lref_ready", lambda self: next(poll, True))
        r = backend.assess_brep(ReadInChild(path, None, False), lref=4.0, jobs=2, with_fields=False)
        assert steps == levels  # both groups' patches, then their children, while "tessellating"
        assert r.vector == here.vector
        assert {m: (v.status, v.value) for m, v in r.validity.items()} == \
            {m: (v.status, v.value) for m, v in here.validity.items()}
        for qa, qb in zip(r.provenance["quadrature"], here.provenance["quadrature"]):
            assert qa["values"] == qb["values"] and qa["errors"] == qb["errors"]
            assert len(qa["parts"]) == 2


def test_the_command_starts_the_reading_process_before_parsing_its_arguments(tmp_path, monkeypatch, capsys):
    """`analyze FILE` of a BRep file starts its reading process before the argument parser and
    the backend load (cli.early_reading, from a plain scan of the arguments), and the
    assessment takes that process over when the parsed arguments ask for the same reading;
    otherwise (here an abbreviated --no-fields the scan does not know) it is stopped and the
    file read by a process of its own: the same numbers either way."""
    import json
    from hullprod_wb import cli
    path = str(tmp_path / "wavy.step")
    wavy_bspline_face().exportStep(path)
    (tmp_path / "hull.stl").write_text("solid x\nendsolid x\n")
    # as in the command, where FreeCAD is never loaded (this test process has it loaded)
    monkeypatch.delitem(sys.modules, "FreeCAD")
    for argv, expected in (([path, "--json"], (None, True)), ([path, "--no-fields"], (None, False)),
                           ([path, "--no-fields", "--out", str(tmp_path / "o")], (None, True)),
                           (["--faces=1", path, "--jobs", "2"], ([1], True))):
        r = cli.early_reading(["analyze"] + argv)
        assert r is not None and (r.faces, r.with_fields, r.path) == expected + (path,)
        r.close()
    r = cli.early_reading(["analyze", path, "--jobs", "1"])  # whatever the processes asked for
    assert r is not None
    r.close()
    for argv in (["analyze", path, "-h"], ["analyze", str(tmp_path / "hull.stl")], ["example"],
                 ["analyze", path, "--backend", "mesh"],
                 ["analyze", str(tmp_path / "missing.step")], ["analyze", path, path]):
        assert cli.early_reading(argv) is None, argv

    monkeypatch.undo()
    # the command in a fresh process (FreeCAD not loaded), counting the reading processes
    driver = ("import sys; from hullprod_wb import cli; from hullprod_wb.brep.reading import record_reader as p\n"
              "init = p.ReadInChild.__init__\n"
              "def counted(self, *a, **k):\n"
              "    sys.stderr.write('reading process for %s\\n' % a[0]); init(self, *a, **k)\n"
              "p.ReadInChild.__init__ = counted\n"
              "sys.exit(cli.main(sys.argv[1:]))\n")
    values = []
    for flag, readers in (("--no-fields", 1), ("--no-field", 2)):
        r = subprocess.run([sys.executable, "-P", "-c", driver, "analyze", path, "--lref", "4", "--json",
                            "--quiet", flag], capture_output=True, text=True, timeout=300,
                           env=dict(os.environ, PYTHONPATH=ROOT))
        assert r.returncode == 0, r.stderr[-2000:]
        doc = json.loads(r.stdout)
        assert doc["provenance"]["reading"].startswith("OpenCascade in a separate process")
        assert r.stderr.count("reading process for %s" % path) == readers, r.stderr
        values.append(doc["signature"])
    assert values[0] == values[1]


def test_faces_with_equal_p_curve_records_share_one_domain():
    """Untrimmed faces on one parameter rectangle have equal p-curve records: their domains
    are built once and are, to the bit, what a build of their own gives; a trimmed face's
    records differ and give its own."""
    import pickle
    from hullprod_wb.brep.geometry import trimmed_domain
    from hullprod_wb.brep.geometry.surface_eval import SurfaceEvaluator
    from hullprod_wb.brep.reading.occ_records import face_record
    faces = [wavy_bspline_face().Faces[0], wavy_bspline_face(7, 4).Faces[0], trimmed_bspline_face()]
    records = [face_record(f, i + 1, i)[0] for i, f in enumerate(faces)]
    assert records[0].pcurves == records[1].pcurves != records[2].pcurves

    def domain(i):
        return trimmed_domain.TrimmedDomain.from_record(records[i], SurfaceEvaluator.for_face(faces[i]))

    trimmed_domain._CLOSED_LOOPS.clear()
    shared = [domain(i) for i in range(3)]
    assert shared[0] is not shared[1] and shared[0].curves is shared[1].curves
    assert shared[2].curves is not shared[0].curves and not shared[2].is_rectangle
    for i in range(3):
        trimmed_domain._CLOSED_LOOPS.clear()
        own = domain(i)
        assert pickle.dumps(own) == pickle.dumps(shared[i])
        assert own.face_parameter_range == shared[i].face_parameter_range == tuple(faces[i].ParameterRange)
