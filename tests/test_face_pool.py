"""Faces integrated in parallel worker processes (brep.face_pool): the same values as one
after the other, the worker count resolved safely, errors and crashes reported."""
import os
import threading

import pytest

from conftest import needs_freecad
from hullprod_wb.brep import face_pool
from hullprod_wb.core.errors import InputError

needs_fork = pytest.mark.skipif(not face_pool.fork_is_safe(), reason="forking is not available here")


@needs_freecad
@needs_fork
def test_parallel_faces_give_the_values_of_the_sequential_run():
    from brep_shapes import hemisphere_with_disc, sphere_cap
    from hullprod_wb import assess
    from hullprod_wb.freecad_env import import_freecad
    import_freecad()
    import Part
    shape = Part.Compound(list(sphere_cap(1.0, 0.5).Faces) + list(hemisphere_with_disc().Faces))
    one = assess(shape, lref=2.0, with_fields=False, jobs=1)
    two = assess(shape, lref=2.0, with_fields=False, jobs=2)
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
    monkeypatch.delenv(face_pool.JOBS_ENV, raising=False)
    assert face_pool.resolve_jobs(1, 5) == 1
    assert face_pool.resolve_jobs(None, 1) == 1  # never more than the faces
    if face_pool.fork_is_safe():
        assert face_pool.resolve_jobs(8, 3) == 3
        assert face_pool.resolve_jobs(None, 64) == face_pool.available_cpus()
    monkeypatch.setenv(face_pool.JOBS_ENV, "1")
    assert face_pool.resolve_jobs(None, 8) == 1
    monkeypatch.setenv(face_pool.JOBS_ENV, "many")
    with pytest.raises(InputError, match="HULLPROD_JOBS"):
        face_pool.resolve_jobs(None, 8)
    for bad in (0, -2, "x"):
        with pytest.raises(InputError, match="jobs must be a positive integer"):
            face_pool.resolve_jobs(bad, 8)


def test_no_workers_from_a_thread():
    seen = []
    t = threading.Thread(target=lambda: seen.append((face_pool.fork_is_safe(), face_pool.resolve_jobs(4, 4))))
    t.start()
    t.join()
    assert seen == [(False, 1)]


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
def test_map_faces_order_progress_and_errors():
    seen = []
    assert face_pool.map_faces(_square, 5, 2, cost=[1, 5, 2, 4, 3], on_done=lambda i, r: seen.append(i)) \
        == [0, 1, 4, 9, 16]
    assert sorted(seen) == list(range(5))
    assert face_pool.map_faces(_square, 3, 1) == [0, 1, 4]
    with pytest.raises(InputError, match="face 2 is broken"):
        face_pool.map_faces(_fails_on_two, 4, 2)
    with pytest.raises(InputError, match="worker process died while integrating .*Face2"):
        face_pool.map_faces(_dies_on_one, 3, 2, labels=["Face1", "Face2", "Face3"])
