"""Faces integrated in parallel worker processes (core.processes): the same values as one
after the other, the worker count resolved safely, errors and crashes reported."""
import math
import os
import threading

import pytest

from conftest import made_in_a_child, needs_freecad
from hullprod_wb.core import processes
from hullprod_wb.core.errors import InputError

needs_fork = pytest.mark.skipif(not processes.fork_is_safe(), reason="forking is not available here")
# a test that forks runs in a fresh process: this one may have meshed (and then forks nothing)
forks = pytest.mark.clean_process


@needs_freecad
@needs_fork
@forks
def test_parallel_faces_give_the_values_of_the_sequential_run():
    from hullprod_wb.examples.analytic_shapes import hemisphere_with_disc, sphere_cap
    from hullprod_wb import assess
    from hullprod_wb.freecad_env import import_freecad
    import_freecad()
    import Part
    shape = made_in_a_child(lambda: Part.Compound(list(sphere_cap(1.0, 0.5).Faces) +
                                                  list(hemisphere_with_disc().Faces)))
    # the parallel run first: the provenance's OpenCascade calls in this process (edge
    # distances) start OpenCascade's threads on FreeCAD 1.x, after which it forks no more
    two = assess(shape, lref=2.0, with_fields=False, jobs=2)
    one = assess(shape, lref=2.0, with_fields=False, jobs=1)
    assert one.options["jobs"] == 1 and two.options["jobs"] == 2
    assert len(shape.Faces) >= 4
    assert two.vector == one.vector  # to the bit
    strip = lambda rows: [{k: v for k, v in r.items() if k != "seconds"} for r in rows]
    assert strip(two.provenance["faces"]) == strip(one.provenance["faces"])
    assert [c["area"] for c in two.provenance["cross_checks"]] == \
        [c["area"] for c in one.provenance["cross_checks"]]
    assert [c["face"] for c in two.provenance["cross_checks"]] == list(range(1, len(shape.Faces) + 1))
    assert {m: v.status for m, v in two.validity.items()} == {m: v.status for m, v in one.validity.items()}


def test_resolve_jobs(monkeypatch):
    monkeypatch.delenv(processes.JOBS_ENV, raising=False)
    assert processes.resolve_jobs(1, 5) == 1
    assert processes.resolve_jobs(None, 1) == 1  # never more than the faces
    if processes.fork_is_safe():
        assert processes.resolve_jobs(8, 3) == 3
        assert processes.resolve_jobs(None, 64) == processes.available_cpus()
    monkeypatch.setenv(processes.JOBS_ENV, "1")
    assert processes.resolve_jobs(None, 8) == 1
    monkeypatch.setenv(processes.JOBS_ENV, "many")
    with pytest.raises(InputError, match="HULLPROD_JOBS"):
        processes.resolve_jobs(None, 8)
    for bad in (0, -2, "x"):
        with pytest.raises(InputError, match="jobs must be a positive integer"):
            processes.resolve_jobs(bad, 8)


def test_no_workers_from_a_thread():
    seen = []
    t = threading.Thread(target=lambda: seen.append((processes.fork_is_safe(), processes.resolve_jobs(4, 4))))
    t.start()
    t.join()
    assert seen == [(False, 1)]


@forks
def test_threads_that_have_ended_do_not_stop_a_fork():
    """join() returns a moment before the kernel has let go of the thread: fork_is_clean
    waits for it, so a digest or a block pass just before a fork never turns the fork
    into a fresh interpreter (the run below saw 2 to 6 in 3000 such joins counted without
    the wait)."""
    from hullprod_wb.core.inputs import Digest
    from hullprod_wb.core.threads import run_blocks
    assert processes.fork_is_clean()
    unclean = 0
    for _ in range(1500):
        Digest(__file__).result()
        unclean += not processes.fork_is_clean()
        run_blocks(lambda sl: None, [slice(0, 1), slice(1, 2)], 2)
        unclean += not processes.fork_is_clean()
    assert unclean == 0


@forks
@pytest.mark.skipif(not os.path.exists("/proc/self/task"), reason="no /proc here")
def test_a_thread_python_did_not_start_stops_forking_at_once():
    """A kernel thread of another library (here one started by libc, as OpenCascade's or
    BLAS's are) is waited for once, then known: fork_is_clean says no at once."""
    import ctypes
    import time
    libc = ctypes.CDLL(None)
    handle = ctypes.c_ulong()
    sleep = ctypes.cast(libc.sleep, ctypes.c_void_p)   # sleep(30) as the thread's routine
    assert libc.pthread_create(ctypes.byref(handle), None, sleep, ctypes.c_void_p(30)) == 0
    t0 = time.monotonic()
    assert not processes.fork_is_clean()
    assert time.monotonic() - t0 >= processes.SETTLE_SECONDS
    t0 = time.monotonic()
    assert not processes.fork_is_clean() and not processes.fork_is_safe()
    assert time.monotonic() - t0 < processes.SETTLE_SECONDS / 2


def _square(i):
    return i * i


def _fails_on_two(i):
    if i == 2:
        raise InputError("face 2 is broken")
    return i


def _dies_on_one(i):
    if i == 1:
        os._exit(3)  # a crash in the geometry kernel, as seen from the parent
    return i


@needs_fork
@forks
def test_map_faces_order_progress_and_errors():
    seen = []
    assert processes.map_faces(_square, 5, 2, cost=[1, 5, 2, 4, 3], on_done=lambda i, r: seen.append(i)) \
        == [0, 1, 4, 9, 16]
    assert sorted(seen) == list(range(5))
    assert processes.map_faces(_square, 3, 1) == [0, 1, 4]
    with pytest.raises(InputError, match="face 2 is broken"):
        processes.map_faces(_fails_on_two, 4, 2)
    with pytest.raises(InputError, match="worker process died while integrating .*Face2"):
        processes.map_faces(_dies_on_one, 3, 2, labels=["Face1", "Face2", "Face3"])


_PARENT = os.getpid()


def _where(i):
    return (i * i, os.getpid() == _PARENT)


@needs_fork
@forks
def test_a_single_item_beside_the_waiting_work_goes_to_a_worker():
    waited = []
    # alone, a single item runs here; beside while_waiting, in a worker while that runs here
    assert processes.map_faces(_where, 1, 2, while_waiting=lambda: waited.append(os.getpid())) == [(0, True)]
    assert processes.map_faces(_where, 1, 2, while_waiting=lambda: waited.append(os.getpid()),
                               beside=True) == [(0, False)]
    assert waited == [_PARENT, _PARENT]
    assert processes.map_faces(_where, 1, 1, beside=True) == [(0, True)]  # no workers: here


def _dies_in_a_child(i):
    if os.getpid() != _PARENT:
        os._exit(3)  # a crash in the geometry kernel, seen from the parent: no result sent
    return i + 10


def _raises_unpicklable(i):
    class Local(Exception):  # a class pickle cannot find: the child cannot send it
        pass
    raise Local("item %d" % i)


@needs_fork
@forks
def test_forked_call_raises_here_what_the_child_could_not_send():
    # the child leaves without sending (it never returns into the caller's code); the call
    # is made here and raises here
    call = processes.ForkedCall(lambda: _raises_unpicklable(1))
    assert call.pid is not None
    with pytest.raises(Exception, match="item 1"):
        call.result()
    assert processes.ForkedCall(lambda: 6 * 7).result() == 42


@needs_fork
@forks
def test_map_forked_same_results_here_or_in_children():
    calls = []
    here = processes.map_forked(_where, 3, 1, while_waiting=lambda: calls.append("wait"))
    forked = processes.map_forked(_where, 3, 3, while_waiting=lambda: calls.append("wait"))
    assert [r for r, _ in here] == [r for r, _ in forked] == [0, 1, 4]
    assert all(local for _, local in here)
    assert [local for _, local in forked] == [True, False, False]  # item 0 here, the others forked
    assert calls == ["wait", "wait"]
    two = processes.map_forked(_where, 4, 2)  # more items than processes: the rest run here
    assert [r for r, _ in two] == [0, 1, 4, 9] and [local for _, local in two] == [True, False, True, True]
    with pytest.raises(InputError, match="face 2 is broken"):
        processes.map_forked(_fails_on_two, 3, 3)
    # a child that dies before sending: its item is done here, with the same result
    assert processes.map_forked(_dies_in_a_child, 3, 3) == [10, 11, 12]


@needs_freecad
@needs_fork
@forks
def test_a_face_assessed_alone_is_integrated_in_patch_groups():
    from hullprod_wb import assess
    from hullprod_wb.brep.cubature import GROUP_MIN_PATCHES
    from hullprod_wb.freecad_env import import_freecad
    import_freecad()
    import Part
    from FreeCAD import Vector as V
    # a bicubic B-spline face of 18 x 16 = 288 knot spans, waves of both signs of K
    nu, nv = 18, 16
    ku = [i / nu for i in range(nu + 1)]
    kv = [j / nv for j in range(nv + 1)]
    mu = [4] + [1] * (nu - 1) + [4]
    mv = [4] + [1] * (nv - 1) + [4]
    poles = [[V(4.0 * i / (nu + 2), 3.0 * j / (nv + 2), 0.2 * math.sin(0.9 * i) * math.cos(0.7 * j))
              for j in range(nv + 3)] for i in range(nu + 3)]
    s = Part.BSplineSurface()
    s.buildFromPolesMultsKnots(poles, mu, mv, ku, kv, False, False, 3, 3)
    face = s.toShape()
    assert nu * nv >= GROUP_MIN_PATCHES
    one = assess(face, lref=4.0, with_fields=False, jobs=1)
    two = assess(face, lref=4.0, with_fields=False, jobs=2)
    assert one.options["group_jobs"] == 1 and two.options["group_jobs"] == 2
    assert two.vector == one.vector  # to the bit: the groups do not depend on the processes
    q = two.provenance["quadrature"][0]
    assert q["patch_groups"] == 2 and sum(p["n_initial_cells"] for p in q["parts"][:2]) == nu * nv
    assert all(q["converged"].values())
    assert two.provenance["cross_checks"] == [dict(c, seconds=t["seconds"]) for c, t in
                                              zip(one.provenance["cross_checks"], two.provenance["cross_checks"])]
    # with another face, the faces share the processes and no face is split
    other = Part.makePlane(1.0, 1.0, V(0, 0, -2))
    both = assess(Part.Compound([face, other]), lref=4.0, with_fields=False, jobs=2)
    q2 = both.provenance["quadrature"][0]
    assert q2["patch_groups"] == 1 and q2["parts"][0]["n_initial_cells"] == nu * nv
    for m in ("I_D", "I_D_plus", "I_D_minus"):
        # the same face integrated whole: within the tolerance (1e-4), not to the bit
        assert both.validity[m].status == one.validity[m].status


@needs_freecad
@needs_fork
@forks
def test_lref_tessellation_in_a_child_is_the_one_made_here():
    from hullprod_wb.examples.analytic_shapes import hemisphere_with_disc
    from hullprod_wb.brep.reading.lref_samples import LrefTessellation, tessellate_faces
    faces = list(hemisphere_with_disc().Faces)
    # the children first: once this process has meshed, it forks no more
    child, killed, unwanted = (LrefTessellation(faces, 0.02) for _ in range(3))
    assert child.call.pid is not None  # running beside this process
    os.kill(killed.call.pid, 9)
    pid = unwanted.call.pid
    pts, tris, seconds = child.result()
    assert seconds >= 0.0 and child.call.pid is None
    # a child killed before it sends: the tessellation is made here, the same
    assert killed.result()[:2] == (pts, tris)
    here = tessellate_faces(faces, 0.02)
    assert len(here[0]) > 0 and len(here[1]) > 0 and len(here[0]) % 3 == 0
    assert (pts, tris) == here
    assert not processes.fork_is_clean()  # OpenCascade's mesher has left its threads here
    assert LrefTessellation(faces, 0.02).call.pid is None
    # a result no longer wanted: the child is stopped and reaped
    unwanted.close()
    with pytest.raises(ChildProcessError):
        os.waitpid(pid, 0)


@needs_freecad
def test_a_file_read_ahead_gives_the_values_of_its_shape(tmp_path):
    from hullprod_wb.examples.analytic_shapes import sphere_cap
    from hullprod_wb import assess
    from hullprod_wb.brep.reading.lref_samples import read_and_start
    path = str(tmp_path / "cap.brep")
    sphere_cap(1.0, 0.5).exportBrep(path)
    inp = read_and_start(path)
    assert inp.read_seconds >= 0.0 and inp.lref_tessellation is not None
    inp.lref_tessellation.close()
    from_file = assess(path, with_fields=False, jobs=1)
    import Part
    shape = Part.Shape()
    shape.importBrep(path)
    from_shape = assess(shape, with_fields=False, jobs=1)
    assert from_file.reference_length.value == from_shape.reference_length.value
    assert from_file.vector == from_shape.vector
