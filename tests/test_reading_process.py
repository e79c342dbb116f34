"""Every OpenCascade read of a user's file runs in a child started from a clean process
(brep.reading.reader_process): a reader that ends the process gives exit 2 with one line; no fork
happens once OpenCascade may have started threads (a script that meshes, then assesses
files); readers started from a fresh interpreter send what forked ones send."""
import json
import math
import os
import re
import subprocess
import sys
import threading

import pytest

from conftest import ROOT, needs_freecad

pytestmark = needs_freecad

HULLPROD = os.path.join(ROOT, "hullprod")
DEATH = re.compile(r"OpenCascade's IGES reader ended the process \((exit \d+|signal \d+, \w+)\); "
                   r"the file is probably damaged$")


def _part():
    from hullprod_wb.freecad_env import import_freecad
    import_freecad()
    import Part
    from FreeCAD import Vector
    return Part, Vector


def wavy_face(nu=4, nv=3):
    Part, V = _part()
    poles = [[V(4.0 * i / (nu + 2), 3.0 * j / (nv + 2), 0.2 * math.sin(0.9 * i) * math.cos(0.7 * j))
              for j in range(nv + 3)] for i in range(nu + 3)]
    s = Part.BSplineSurface()
    s.buildFromPolesMultsKnots(poles, [4] + [1] * (nu - 1) + [4], [4] + [1] * (nv - 1) + [4],
                               [i / nu for i in range(nu + 1)], [j / nv for j in range(nv + 1)],
                               False, False, 3, 3)
    return s.toShape()


def damaged_iges(tmp_path):
    """An IGES file of a B-spline face whose first B-spline curve entity (126) has its
    degree and pole-count fields overwritten in the data section ("126,999,"): OpenCascade's
    IGES reader ends the process on it (FreeCAD 0.20.2 and 1.0: exit 1)."""
    good = str(tmp_path / "good.igs")
    wavy_face().exportIges(good)
    with open(good, "rb") as fh:
        lines = fh.read().split(b"\n")
    for i, line in enumerate(lines):
        if line[72:73] == b"P" and line.startswith(b"126,"):
            k = line.index(b",", line.index(b",", 4) + 1) + 1  # after "126,K,M,"
            lines[i] = (b"126,999," + line[k:64]).ljust(64)[:64] + line[64:]
            break
    else:
        raise AssertionError("no B-spline curve entity in the generated IGES file")
    path = str(tmp_path / "damaged.igs")
    with open(path, "wb") as fh:
        fh.write(b"\n".join(lines))
    return path


def test_a_damaged_iges_that_ends_the_reader_gives_exit_2(tmp_path):
    path = damaged_iges(tmp_path)
    # OpenCascade's reader itself ends the process that reads it (FreeCAD's own Python too)
    bare = subprocess.run([sys.executable, "-c", "import sys; sys.path.append(%r); import FreeCAD, Part; "
                           "Part.read(%r); print('read')" % ("/usr/lib/freecad-python3/lib", path)],
                          capture_output=True, text=True, timeout=120)
    assert bare.returncode != 0 and "read" not in bare.stdout.split()
    for extra in ([], ["--jobs", "1"], ["--json"], ["--faces", "1", "--no-fields"]):
        p = subprocess.run([HULLPROD, "analyze", path, "--quiet"] + extra, capture_output=True, text=True,
                           timeout=300)
        assert p.returncode == 2, (extra, p.returncode, p.stderr[-2000:])
        lines = p.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("hullprod: error: %s: " % path), p.stderr
        assert DEATH.search(lines[0]), lines[0]
        assert p.stdout == ""
    # from Python, and as a batch case's error row
    from hullprod_wb import assess
    from hullprod_wb.batch.cases import Case, make_settings
    from hullprod_wb.batch.worker import run_case
    from hullprod_wb.core.errors import ReaderDied
    with pytest.raises(ReaderDied) as err:
        assess(path)
    assert DEATH.search(str(err.value))
    record = run_case(Case("damaged", "file", path, None, "brep"), make_settings(), "h")
    assert record["status"] == "error" and record["error"]["type"] == "ReaderDied"
    assert DEATH.search(record["error"]["message"])


# A script of its own: mesh a shape (OpenCascade starts its threads here), then assess
# files again and again, with every fork of the process checked (os.fork wrapped).
MESH_THEN_ASSESS = r"""
import json, os, sys
sys.path.insert(0, %(root)r)
from hullprod_wb.core import processes
from hullprod_wb.freecad_env import import_freecad
forks = []
fork = os.fork
def counted():
    forks.append(processes.thread_count())
    return fork()
os.fork = counted
import_freecad()
import Part
import hullprod_wb
Part.makeSphere(1.0).tessellate(0.01)  # the script's own meshing
meshed_threads = processes.thread_count()
out = {"meshed_threads": meshed_threads, "values": []}
for _ in range(4):
    for path in sys.argv[1:]:
        r = hullprod_wb.assess(path, lref=4.0, with_fields=True)
        out["values"].append([path, r.signature["I_D"], r.signature["a_C"], r.options["jobs"]])
out["forks_with_threads"] = [n for n in forks if n != 1]
out["forks"] = len(forks)
print(json.dumps(out))
"""


def test_a_script_that_meshes_then_assesses_files_forks_nothing(tmp_path):
    """Once the process has meshed (OpenCascade's threads are running), files are still
    read in children (fresh interpreters, not forks) and the faces integrated here: the
    values of the command, repeatedly, and no fork of a process with threads."""
    Part, V = _part()
    wavy, mixed = str(tmp_path / "wavy.step"), str(tmp_path / "mixed.step")
    wavy_face().exportStep(wavy)
    Part.Compound([wavy_face(3, 3), Part.makeCylinder(0.5, 1.0, V(0, 0, 1)).Faces[0]]).exportStep(mixed)
    script = MESH_THEN_ASSESS % {"root": ROOT}
    p = subprocess.run([sys.executable, "-c", script, wavy, mixed], capture_output=True, text=True, timeout=600,
                       env=dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1"))
    assert p.returncode == 0, p.stderr[-3000:]
    out = json.loads(p.stdout.strip().splitlines()[-1])
    assert out["meshed_threads"] > 1
    assert out["forks_with_threads"] == []
    assert {v[3] for v in out["values"]} == {1}  # the faces integrated in the script's process
    for path in (wavy, mixed):
        c = subprocess.run([HULLPROD, "analyze", path, "--lref", "4", "--json", "--quiet"], capture_output=True,
                           text=True, timeout=300)
        assert c.returncode == 0, c.stderr[-2000:]
        doc = json.loads(c.stdout)
        runs = [v for v in out["values"] if v[0] == path]
        assert len(runs) == 4 and all(v[1:3] == runs[0][1:3] for v in runs)
        # another process count and BLAS state: the same to rounding, not to the bit
        assert runs[0][1] == pytest.approx(doc["signature"]["I_D"], rel=1e-12, abs=1e-300)
        for k, v in doc["signature"]["a_C"].items():
            assert runs[0][2][k] == pytest.approx(v, rel=1e-9, abs=1e-12)


@pytest.mark.clean_process
def test_a_reader_from_a_fresh_interpreter_sends_what_a_forked_one_sends(tmp_path):
    from hullprod_wb.core import processes
    from hullprod_wb.brep.reading.record_reader import ReadInChild
    Part, V = _part()
    path = str(tmp_path / "mixed.step")
    Part.Compound([wavy_face(), Part.makePlane(1.0, 1.0, V(0, 0, -2))]).exportStep(path)
    assert processes.fork_is_clean()
    forked = ReadInChild(path, None, True)
    assert forked._child._pid is not None
    stop = threading.Event()
    other = threading.Thread(target=stop.wait)
    other.start()  # a second thread: no fork from here now
    try:
        assert not processes.fork_is_clean()
        fresh = ReadInChild(path, None, True)
        assert fresh._child._pid is None and fresh._child._popen is not None
    finally:
        stop.set()
        other.join()
    a = [forked.faces_frame(), forked.lref_frame(), forked.display_frame(), forked.late_frame()]
    b = [fresh.faces_frame(), fresh.lref_frame(), fresh.display_frame(), fresh.late_frame()]
    assert a[2].display is not None and len(a[2].display) == len(a[0].faces)
    strip = lambda f: {k: v for k, v in vars(f).items() if k not in ("read_seconds", "seconds")}
    assert [strip(f) for f in a] == [strip(f) for f in b]
    forked.close()
    fresh.close()


def test_a_reader_that_stalls_is_stopped_at_the_time_limit(tmp_path, monkeypatch):
    """A reading process that sends nothing within the file's read time limit is stopped,
    and the reading ends as a damaged file (ReaderDied, an InputError: exit 2)."""
    import time
    from hullprod_wb.brep.reading.reader_process import ReaderProcess
    from hullprod_wb.core.errors import ReaderDied
    path = tmp_path / "stalls.brep"
    path.write_text("DBRep_DrawableShape\n")
    monkeypatch.setenv("HULLPROD_READ_TIME_LIMIT", "1")
    t = time.monotonic()
    proc = ReaderProcess(str(path), ("time", "sleep"), (30,))
    with pytest.raises(ReaderDied, match="did not finish within 1 s; the file is probably damaged"):
        proc.receive()
    assert time.monotonic() - t < 10
    proc.close()
