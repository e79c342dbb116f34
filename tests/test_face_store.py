"""The BRep faces' store: entries that are whole or ignored, least-recently-used bounds,
exact keys, and incremental assessments equal to cold ones (core.result_store,
brep.face_keys, brep.backend)."""
import errno
import json
import multiprocessing
import os
import subprocess
import sys

import numpy as np
import pytest

from conftest import ROOT, needs_freecad
from hullprod_wb.core import result_store
from hullprod_wb.core.errors import InputError
from hullprod_wb.core.result_store import ResultStore, open_store, parse_size

KEY = "ab" * 32
OTHER = "cd" * 32


def test_entries_round_trip_and_count(tmp_path):
    s = ResultStore(tmp_path / "store")
    assert s.get(KEY) is None
    assert s.put(KEY, {"values": [1.0, -0.0, np.float64(2.5)]})
    got = s.get(KEY)
    assert got["values"][0] == 1.0 and str(got["values"][1]) == "-0.0" and got["values"][2] == 2.5
    c = s.counts
    assert (c.hits, c.misses, c.written, c.damaged) == (1, 1, 1, 0)
    assert c.bytes_read == c.bytes_written == os.path.getsize(s.path(KEY)) > 0
    assert oct(os.stat(os.path.dirname(s.path(KEY))).st_mode & 0o777) == oct(0o700)


def test_a_shard_folder_is_made_once_and_again_when_it_was_removed(tmp_path, monkeypatch):
    import shutil
    s = ResultStore(tmp_path / "store")
    made = []
    real = os.makedirs
    monkeypatch.setattr(result_store.os, "makedirs", lambda *a, **k: (made.append(a[0]), real(*a, **k))[1])
    same_shard = [KEY[:2] + "%062x" % i for i in range(3)]
    for k in same_shard:
        assert s.put(k, {"k": k})
    shard = os.path.dirname(s.path(KEY))
    assert made.count(shard) == 1
    shutil.rmtree(shard)  # a user removed it meanwhile
    assert s.put(same_shard[0], {"k": "again"}) and s.get(same_shard[0]) == {"k": "again"}
    assert made.count(shard) == 2 and s.writable and not s.counts.write_errors


@pytest.mark.parametrize("damage", ["truncate", "flip", "other_key", "empty", "garbage"])
def test_a_damaged_entry_is_ignored_and_removed(tmp_path, damage):
    s = ResultStore(tmp_path)
    s.put(KEY, list(range(1000)))
    path = s.path(KEY)
    data = open(path, "rb").read()
    if damage == "truncate":
        data = data[:len(data) // 2]
    elif damage == "flip":
        i = len(data) - 10
        data = data[:i] + bytes([data[i] ^ 1]) + data[i + 1:]
    elif damage == "other_key":  # a whole entry of another key under this name
        s.put(OTHER, list(range(1000)))
        data = open(s.path(OTHER), "rb").read()
    elif damage == "empty":
        data = b""
    else:
        data = os.urandom(500)
    with open(path, "wb") as fh:
        fh.write(data)
    assert s.get(KEY) is None
    assert s.counts.damaged == 1 and s.counts.hits == 0
    assert not os.path.exists(path)
    assert s.put(KEY, [1, 2]) and s.get(KEY) == [1, 2]  # recomputed and stored again


def test_a_full_disk_turns_writing_off_and_loses_nothing(tmp_path, monkeypatch):
    s = ResultStore(tmp_path)
    s.put(KEY, "kept")

    def full(path, mode="r", *args, **kw):
        if "w" in mode:
            raise OSError(errno.ENOSPC, "No space left on device")
        return open(path, mode, *args, **kw)
    monkeypatch.setattr(result_store, "open", full, raising=False)
    assert s.put(OTHER, "lost") is False
    assert s.writable is False and s.counts.write_errors and "ENOSPC" in s.counts.write_errors[0]
    assert s.put(OTHER, "again") is False and len(s.counts.write_errors) == 1  # no retry per face
    monkeypatch.undo()
    assert s.get(KEY) == "kept" and s.get(OTHER) is None
    assert not [n for n in os.listdir(os.path.dirname(s.path(OTHER))) if ".tmp-" in n]


def test_prune_removes_the_least_recently_used(tmp_path):
    s = ResultStore(tmp_path)
    keys = ["%02x" % i + "0" * 62 for i in range(6)]
    for i, k in enumerate(keys):
        s.put(k, bytes(1000))
        os.utime(s.path(k), (1000.0 + i, 1000.0 + i))  # written one after the other
    s.get(keys[0])  # used now: the most recent
    size = os.path.getsize(s.path(keys[0]))
    s.max_bytes = 3 * size
    assert s.prune() == 3
    assert [s.get(k) is not None for k in keys] == [True, False, False, False, True, True]
    assert s.size() == 3 * size


def test_prune_removes_stale_temporary_files(tmp_path):
    s = ResultStore(tmp_path)
    s.put(KEY, 1)
    stale = s.path(KEY) + ".tmp-1-1"
    fresh = s.path(KEY) + ".tmp-2-2"
    for p in (stale, fresh):
        open(p, "wb").close()
    os.utime(stale, (0, 0))
    s.prune()
    assert not os.path.exists(stale) and os.path.exists(fresh)


def _hammer(folder, value, rounds, q):
    s = ResultStore(folder)
    seen = set()
    for _ in range(rounds):
        s.put(KEY, value)
        got = s.get(KEY)
        seen.add(None if got is None else got[0])
    q.put((seen, s.counts.damaged))


def test_two_writers_at_once_leave_whole_entries(tmp_path):
    big = [float(i) for i in range(20000)]
    q = multiprocessing.get_context("spawn").Queue()
    procs = [multiprocessing.get_context("spawn").Process(target=_hammer, args=(str(tmp_path), [k] + big, 60, q))
             for k in ("a", "b")]
    for p in procs:
        p.start()
    results = [q.get(timeout=120) for _ in procs]
    for p in procs:
        p.join(timeout=60)
    for seen, damaged in results:
        assert damaged == 0 and seen <= {"a", "b"}
    got = ResultStore(tmp_path).get(KEY)
    assert got[0] in ("a", "b") and got[1:] == big
    assert not [n for n in os.listdir(os.path.dirname(ResultStore(tmp_path).path(KEY))) if ".tmp-" in n]


def test_where_the_store_is(tmp_path, monkeypatch):
    monkeypatch.delenv(result_store.FOLDER_ENV, raising=False)
    monkeypatch.delenv(result_store.SIZE_ENV, raising=False)
    s, how = open_store(None, str(tmp_path / "cache"))
    assert s.folder == str(tmp_path / "cache" / "HullProd" / "faces") and "FreeCAD" in how
    assert s.max_bytes == 2 * 1024 ** 3
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert open_store(None, None)[0].folder == str(tmp_path / "xdg" / "FreeCAD" / "Cache" / "HullProd" / "faces")
    monkeypatch.setenv(result_store.FOLDER_ENV, str(tmp_path / "env"))
    monkeypatch.setenv(result_store.SIZE_ENV, "512M")
    s, how = open_store(None, None)
    assert s.folder == str(tmp_path / "env") and s.max_bytes == 512 * 1024 ** 2 and "HULLPROD_FACE_CACHE" in how
    assert open_store(str(tmp_path / "given"), None)[0].folder == str(tmp_path / "given")
    monkeypatch.setenv(result_store.FOLDER_ENV, "off")
    assert open_store(None, None)[0] is None
    assert open_store(False, None)[0] is None
    (tmp_path / "file").write_text("x")
    with pytest.raises(InputError, match="not a folder"):
        open_store(str(tmp_path / "file"), None)


def test_sizes_read_as_people_write_them():
    assert parse_size("2G") == 2 * 1024 ** 3 and parse_size("100k") == 102400 and parse_size("7") == 7
    assert parse_size("1.5MB") == int(1.5 * 1024 ** 2)
    for bad in ("lots", "-1G", ""):
        with pytest.raises(InputError):
            parse_size(bad)


def test_keys_are_exact():
    from array import array
    from hullprod_wb.core.exact_keys import canonical_bytes, digest
    assert digest(0.0) != digest(-0.0) and digest(1) != digest(1.0) and digest("1") != digest(1)
    assert digest([1.0, 2.0]) != digest([2.0, 1.0]) and digest({"a": 1, "b": 2}) != digest({"b": 2, "a": 1})
    assert digest(1.0) != digest(np.nextafter(1.0, 2.0))
    assert digest(array("d", [1.0, 2.0])) == digest(array("d", [1.0, 2.0]))
    assert digest(np.arange(3.0)) != digest(np.arange(3.0).reshape(3, 1))
    assert canonical_bytes([["ab"], "c"]) != canonical_bytes([["a"], "bc"])
    with pytest.raises(TypeError):
        canonical_bytes(object())


def test_a_record_key_ignores_the_face_number_only():
    from dataclasses import replace
    from hullprod_wb.brep.reading.record_keys import record_digest
    from hullprod_wb.brep.reading.occ_records import FaceData
    rec = FaceData(number=3, surface_type="BSplineSurface", kind="bspline", part=1, patch_count=4,
                   occ_reference=[[1.0, 2.0]], nurbs={"poles": [0.0, 1.0, 2.0]}, orientation_sign=1)
    assert record_digest(replace(rec, number=9, part=0)) == record_digest(rec)
    assert record_digest(replace(rec, nurbs={"poles": [0.0, 1.0, 2.0000000000000004]})) != record_digest(rec)
    assert record_digest(replace(rec, orientation_sign=-1)) != record_digest(rec)
    data = replace(rec, kind="part", nurbs=None)
    assert record_digest(data) is None  # a face sent as data without a digest of its data: never stored
    assert record_digest(replace(data, data_digest="0" * 64)) != record_digest(replace(data, data_digest="1" * 64))


# --- claims: runs sharing a store make each result once ------------------------------------

def test_a_claim_binds_other_runs_until_released(tmp_path):
    from hullprod_wb.core import result_claims as rc
    entry = str(tmp_path / "ab" / (KEY + ".entry"))
    me, other = rc.owner(), rc.owner(os.getppid())
    assert rc.take(entry, me) and rc.take(entry, me)  # made, then held already
    assert not rc.take(entry, other) and rc.held_elsewhere(entry, other) and not rc.held_elsewhere(entry, me)
    rc.release(entry, other)  # not its claim: stays
    assert rc.held_elsewhere(entry, other)
    rc.release(entry, me)
    assert not rc.held_elsewhere(entry, other) and rc.take(entry, other)


def test_claims_are_links_to_the_runs_owner_file_else_files_of_their_own(tmp_path, monkeypatch):
    from hullprod_wb.core import result_claims as rc
    store = ResultStore(tmp_path)
    keys = [("%02x" % k) * 32 for k in range(3)]
    me = rc.owner()
    assert all(rc.take(store.path(k), me) for k in keys)
    owner = rc.owner_file(store.path(keys[0]), me)
    st = os.stat(owner)
    assert open(owner).read() == me + "\n" and st.st_nlink == 1 + len(keys)
    assert all(os.stat(store.path(k) + rc.SUFFIX).st_ino == st.st_ino for k in keys)  # no inode of their own
    for k in keys:
        rc.release(store.path(k), me)
    assert os.stat(owner).st_nlink == 1 and not rc.held_elsewhere(store.path(keys[0]), rc.owner(os.getppid()))

    def no_links(*a):
        raise PermissionError(1, "Operation not permitted")
    monkeypatch.setattr(os, "link", no_links)  # a file system without hard links
    entry, other = store.path(keys[1]), rc.owner(os.getppid())
    assert rc.take(entry, me) and os.stat(entry + rc.SUFFIX).st_ino != st.st_ino
    assert not rc.take(entry, other) and rc.held_elsewhere(entry, other)
    rc.release(entry, me)
    assert rc.take(entry, other)


def test_dead_claims_are_taken_over(tmp_path):
    import time
    from hullprod_wb.core import result_claims as rc
    entry = ResultStore(tmp_path).path(KEY)
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    dead = rc.owner(p.pid)  # a process of this host that has ended
    assert rc.take(entry, dead) and not rc.held_elsewhere(entry, rc.owner()) and rc.take(entry, rc.owner())
    os.unlink(entry + rc.SUFFIX)
    z = subprocess.Popen([sys.executable, "-c", "pass"])  # ended and not yet waited for: a zombie
    while not os.path.exists("/proc/%d" % z.pid) or b") Z" not in open("/proc/%d/stat" % z.pid, "rb").read():
        time.sleep(0.01)
    assert rc.take(entry, rc.owner(z.pid)) and not rc.held_elsewhere(entry, rc.owner())
    z.wait()
    os.unlink(entry + rc.SUFFIX)
    far = "another-host 1"
    assert rc.take(entry, far) and rc.held_elsewhere(entry, rc.owner())  # another host: by its age
    old = os.path.getmtime(entry + rc.SUFFIX) - rc.FOREIGN_CLAIM_S - 1
    os.utime(entry + rc.SUFFIX, (old, old))
    assert not rc.held_elsewhere(entry, rc.owner()) and rc.take(entry, rc.owner())
    os.utime(entry + rc.SUFFIX, (old - rc.CLAIM_LIFETIME_S,) * 2)
    assert ResultStore(tmp_path).entries() == [] and not os.path.exists(entry + rc.SUFFIX)  # prune's scan


def test_a_claim_that_cannot_be_written_does_not_stop_a_run(tmp_path):
    from hullprod_wb.core import result_claims as rc
    blocked = tmp_path / "file"
    blocked.write_text("")
    assert rc.take(str(blocked / "ab" / (KEY + ".entry")), rc.owner())  # its folder cannot be made


# --- assessments through the store -------------------------------------------------------

def patches(bumps=(), n=3):
    """analytic_shapes.patch_grid: n x n Bezier patches, bumps (index, dz) moving a pole."""
    from hullprod_wb.examples.analytic_shapes import patch_grid
    return patch_grid(bumps, n)


def write_shape(path, faces):
    import Part
    Part.Compound(faces).exportBrep(str(path))
    return str(path)


def analyze(path, store, *extra, env=None):
    p = subprocess.run([os.path.join(ROOT, "hullprod"), "analyze", path, "--json", "--quiet", "--no-fields",
                        "--lref", "4"] + (["--cache", str(store)] if store else ["--no-cache"]) + list(extra),
                       capture_output=True, text=True, timeout=600,
                       env=dict(os.environ, HULLPROD_FACE_CACHE="off", **(env or {})))
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout)


def comparable(doc):
    """The document without what differs between equal runs: timings (the run's, and the
    seconds a face's area rule took), the store's record."""
    def strip(x):
        if isinstance(x, dict):
            return {k: strip(v) for k, v in x.items() if k != "seconds"}
        return [strip(v) for v in x] if isinstance(x, list) else x
    doc = json.loads(json.dumps(doc))
    doc.pop("timings")
    doc["provenance"].pop("cache")
    return strip(doc)


@needs_freecad
def test_a_warm_run_equals_a_cold_one_bit_for_bit(tmp_path):
    path = write_shape(tmp_path / "hull.brep", patches())
    store = tmp_path / "store"
    cold = analyze(path, store)
    assert cold["provenance"]["cache"]["written"] == 9 and cold["provenance"]["cache"]["hits"] == 0
    warm = analyze(path, store)
    c = warm["provenance"]["cache"]
    assert c["hits"] == 9 and c["misses"] == 0 and c["written"] == 0 and c["faces_from_store"] == list(range(1, 10))
    # the reading process keeps OpenCascade's face areas there too
    assert cold["provenance"]["cache"]["occ_areas_from_store"] == {"hits": 0, "misses": 9}
    assert c["occ_areas_from_store"] == {"hits": 9, "misses": 0}
    assert cold["provenance"]["cache"]["edge_reports_from_store"] == {"hits": 0, "misses": 9}
    assert c["edge_reports_from_store"] == {"hits": 9, "misses": 0}
    assert comparable(warm) == comparable(cold)
    assert comparable(analyze(path, None)) == comparable(cold)  # the store changes nothing


def blas_identity_with(threads):
    """core.blas_identity.blas_identity() of a fresh interpreter with OPENBLAS_NUM_THREADS=threads."""
    code = "import json; from hullprod_wb.core.blas_identity import blas_identity; print(json.dumps(blas_identity()))"
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=ROOT,
                       env=dict(os.environ, OPENBLAS_NUM_THREADS=str(threads), OMP_NUM_THREADS=str(threads)))
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout)


def test_the_blas_identity_names_the_library_and_its_threads():
    one, two = blas_identity_with(1), blas_identity_with(2)
    if one[0] == "unknown":
        pytest.skip("numpy's BLAS cannot be told in this process")
    assert one[:2] == two[:2]  # the same library and kernel
    if one[2] is None:  # a library that does not tell its threads is named by its file
        assert one[0] == "library" and os.path.isfile(one[1]) and two[2] is None
    else:  # OpenBLAS takes at most as many threads as it sees CPUs
        assert (one[2], two[2]) == (1, min(2, os.cpu_count()))


def test_the_settings_digest_holds_the_blas_identity(monkeypatch):
    from hullprod_wb.brep import face_keys
    from hullprod_wb.brep.validity.budget import quadrature_options
    from hullprod_wb.core.thresholds import Thresholds
    args = (7.0, Thresholds(7.0, 1e-3, 1e-3), quadrature_options(), False, True, "7.6.3", "records")
    monkeypatch.setattr(face_keys, "blas_identity", lambda: ["openblas", "OpenBLAS 0.3.21 Haswell", 1])
    one = face_keys.settings_digest(*args)
    assert face_keys.settings_digest(*args) == one
    monkeypatch.setattr(face_keys, "blas_identity", lambda: ["openblas", "OpenBLAS 0.3.21 Haswell", 2])
    assert face_keys.settings_digest(*args) != one
    monkeypatch.setattr(face_keys, "blas_identity", lambda: ["openblas", "OpenBLAS 0.3.21 SkylakeX", 1])
    assert face_keys.settings_digest(*args) != one


@needs_freecad
def test_faces_made_with_other_blas_threads_are_not_reused(tmp_path):
    """The last bits of a product depend on OpenBLAS's threads: a run with two does not take
    the faces a run with one stored, and a run with one again takes them all."""
    if blas_identity_with(1)[2] is None:
        pytest.skip("numpy's BLAS does not tell its threads here")
    path = write_shape(tmp_path / "hull.brep", patches())
    store = tmp_path / "store"
    assert analyze(path, store, env={"OPENBLAS_NUM_THREADS": "1"})["provenance"]["cache"]["written"] == 9
    two = analyze(path, store, env={"OPENBLAS_NUM_THREADS": "2"})["provenance"]["cache"]
    assert two["hits"] == 0 and two["written"] == 9
    assert analyze(path, store, env={"OPENBLAS_NUM_THREADS": "1"})["provenance"]["cache"]["hits"] == 9


@needs_freecad
def test_changed_faces_are_integrated_again_and_the_rest_reused(tmp_path):
    store = tmp_path / "store"
    base = analyze(write_shape(tmp_path / "base.brep", patches()), store)
    for name, bumps in (("one", [(4, 0.02)]), ("several", [(0, 0.01), (5, -0.02), (8, 0.03)])):
        path = write_shape(tmp_path / (name + ".brep"), patches(bumps))
        inc = analyze(path, store)
        changed = sorted(k + 1 for k, _ in bumps)
        c = inc["provenance"]["cache"]
        assert c["faces_from_store"] == [f for f in range(1, 10) if f not in changed], name
        assert c["written"] == len(changed)
        cold = analyze(path, None)
        assert comparable(inc) == comparable(cold), name
        # the edited faces' parts of the edge report, and their neighbours', are made again
        assert inc["provenance"]["cache"]["edge_reports_from_store"]["misses"] >= len(changed), name
        assert inc["signature"]["I_D"] != base["signature"]["I_D"]


@needs_freecad
def test_a_face_count_change_reuses_the_faces_whose_keys_match(tmp_path):
    store = tmp_path / "store"
    faces = patches()
    analyze(write_shape(tmp_path / "base.brep", faces), store)
    # face 5 removed: the rest renumbered, and their shares of the point budget grow
    fewer = write_shape(tmp_path / "fewer.brep", faces[:4] + faces[5:])
    inc = analyze(fewer, store)
    assert inc["provenance"]["cache"]["hits"] == 8
    assert [r["face"] for r in inc["provenance"]["faces"]] == list(range(1, 9))
    assert comparable(inc) == comparable(analyze(fewer, None))


@needs_freecad
def test_faces_whose_budget_changed_are_reused_where_the_budget_never_bound_them(tmp_path):
    path = write_shape(tmp_path / "hull.brep", patches())
    store = tmp_path / "store"
    tight = analyze(path, store, "--point-budget", "2000")  # 2,000 points a face: the budget binds some
    bound = [f["face"] for f in tight["provenance"]["quadrature"]
             if any(p["budget_needed"] is None for p in f["parts"])]
    assert 0 < len(bound) < 9
    # every face's budget changes; a face the budget bound is integrated again (and then
    # stored free of it), the others are taken as they were
    for budget, reused in (("3000000", [f for f in range(1, 10) if f not in bound]),
                           ("9000000", list(range(1, 10)))):
        inc = analyze(path, store, "--point-budget", budget)
        assert inc["provenance"]["cache"]["faces_from_store"] == reused, budget
        # the parts' point budgets too: those this run gave them
        assert comparable(inc) == comparable(analyze(path, None, "--point-budget", budget)), budget


def test_a_new_face_leaves_most_other_budgets_as_they_were():
    from hullprod_wb.brep.validity.budget import face_point_budgets, quadrature_options
    rng = np.random.default_rng(5)
    area = rng.lognormal(0.0, 2.0, 300)
    opts = quadrature_options(point_budget=400_000_000)  # most faces above the floor
    before = face_point_budgets(opts, area / area.sum())
    grown = np.append(area, area.mean())
    after = face_point_budgets(opts, grown / grown.sum())[:-1]
    above = [i for i, b in enumerate(before) if b > 100_000]
    assert len(above) > 100
    same = sum(before[i] == after[i] for i in above)
    assert same >= 0.9 * len(above)
    assert sum(before) <= 400_000_000 + 100_000 * len(before)


@needs_freecad
def test_a_damaged_entry_in_an_assessment_is_recomputed(tmp_path):
    path = write_shape(tmp_path / "hull.brep", patches())
    store = tmp_path / "store"
    cold = analyze(path, store)
    entries = sorted(os.path.join(d, f) for d, _, fs in os.walk(store) for f in fs if f.endswith(".entry"))
    assert len(entries) == 27  # nine faces' results, areas and parts of the edge report
    with open(max(entries, key=os.path.getsize), "r+b") as fh:  # a face's result
        fh.seek(-20, os.SEEK_END)
        fh.write(b"\0" * 8)
    warm = analyze(path, store)
    c = warm["provenance"]["cache"]
    assert (c["hits"], c["damaged_entries_ignored"], c["written"]) == (8, 1, 1)
    assert comparable(warm) == comparable(cold)


@needs_freecad
def test_two_assessments_at_once_share_a_store(tmp_path):
    path = write_shape(tmp_path / "hull.brep", patches())
    store = tmp_path / "store"
    cmd = [os.path.join(ROOT, "hullprod"), "analyze", path, "--json", "--quiet", "--no-fields", "--lref", "4",
           "--cache", str(store), "--jobs", "1"]
    runs = [subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for _ in range(2)]
    docs = []
    for p in runs:
        out, err = p.communicate(timeout=600)
        assert p.returncode == 0, err
        docs.append(json.loads(out))
    assert comparable(docs[0]) == comparable(docs[1])
    # each face integrated once: by one run, the other taking it from the store or awaiting it
    assert sum(d["provenance"]["cache"]["written"] for d in docs) == 9
    third = analyze(path, store, "--jobs", "1")
    assert third["provenance"]["cache"]["hits"] == 9 and comparable(third) == comparable(docs[0])


@needs_freecad
def test_a_part_shape_in_process_uses_the_store_and_survives_a_full_disk(tmp_path, monkeypatch):
    import Part
    from hullprod_wb.brep.backend import assess_brep
    shape = Part.Compound(patches(n=2))
    kw = dict(lref=4.0, with_fields=False, jobs=1)
    cold = assess_brep(shape, cache=str(tmp_path), **kw).to_dict()
    warm = assess_brep(shape, cache=str(tmp_path), **kw).to_dict()
    assert warm["provenance"]["cache"]["hits"] == 4 and comparable(warm) == comparable(cold)

    def full(path, mode="r", *args, **kw):
        if "w" in mode:
            raise OSError(errno.ENOSPC, "No space left on device")
        return open(path, mode, *args, **kw)
    monkeypatch.setattr(result_store, "open", full, raising=False)
    other = Part.Compound(patches([(1, 0.05)], n=2))
    full_disk = assess_brep(other, cache=str(tmp_path / "new"), **kw).to_dict()
    monkeypatch.undo()
    c = full_disk["provenance"]["cache"]
    assert c["written"] == 0 and "ENOSPC" in c["write_errors"][0]
    assert comparable(full_disk) == comparable(assess_brep(other, cache=False, **kw).to_dict())
    assert assess_brep(other, cache=False, **kw).to_dict()["provenance"]["cache"] == {
        "enabled": False, "source": "off (--no-cache, cache=False)"}


@needs_freecad
def test_faces_another_run_claimed_are_awaited_and_made_here_when_it_ends(tmp_path):
    import time
    import Part
    from hullprod_wb.brep.backend import assess_brep
    from hullprod_wb.core import result_claims as rc
    shape = Part.Compound(patches(n=2))
    kw = dict(lref=4.0, with_fields=False, jobs=1)
    cold = assess_brep(shape, cache=str(tmp_path / "a"), **kw).to_dict()
    keys = [os.path.basename(e[2])[:-len(".entry")] for e in ResultStore(tmp_path / "a").entries()]
    import threading
    holder = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(1.5)"])  # a run that dies unfinished
    reaped = threading.Thread(target=holder.wait)  # reaped as it ends (a zombie would still be a process)
    reaped.start()
    b = ResultStore(tmp_path / "b")
    for key in keys:
        assert rc.take(b.path(key), rc.owner(holder.pid))
    t = time.monotonic()
    late = assess_brep(shape, cache=b, **kw).to_dict()
    reaped.join()
    assert time.monotonic() - t >= 1.0 and holder.returncode == 0  # it waited for the holder
    c = late["provenance"]["cache"]
    assert (c["written"], c["awaited"]) == (4, 0) and comparable(late) == comparable(cold)
    assert not any(n.endswith(rc.SUFFIX) for _, _, fs in os.walk(tmp_path / "b") for n in fs)


@needs_freecad
def test_display_samples_come_from_the_store_as_they_were_made(tmp_path):
    from hullprod_wb.api import assess
    path = write_shape(tmp_path / "hull.brep", patches())
    cold = assess(path, lref=4.0, cache=str(tmp_path / "store"), jobs=1)
    warm = assess(path, lref=4.0, cache=str(tmp_path / "store"), jobs=1)
    assert cold.to_dict()["provenance"]["cache"]["written"] == 18  # nine faces' results and samples
    assert warm.to_dict()["provenance"]["cache"]["hits"] == 18
    for k in ("points", "triangles", "K", "H", "valid"):
        assert np.array_equal(getattr(warm.fields, k), getattr(cold.fields, k)), k
    for k in ("face_id", "k1", "k2"):
        assert np.array_equal(warm.fields.extra[k], cold.fields.extra[k]), k


def test_the_command_refuses_contradicting_store_options(tmp_path):
    p = subprocess.run([sys.executable, "-m", "hullprod_wb.cli", "analyze", "x.igs", "--cache", str(tmp_path),
                        "--no-cache"], capture_output=True, text=True, cwd=ROOT)
    assert p.returncode == 2 and "contradict" in p.stderr


def _fields(a):
    f = a.fields
    return [f.points, f.triangles, f.K, f.H, f.valid] + [f.extra[k] for k in sorted(f.extra)]


@needs_freecad
def test_display_meshes_of_a_sewn_shape_come_back_as_a_cold_run_makes_them(tmp_path):
    """Faces sharing edges: the edited face and the faces sharing an edge with it are meshed
    again, their earlier neighbours first, and every field array equals a cold run's."""
    import Part
    from hullprod_wb import api
    sewn = Part.Shell(patches())
    sewn.sewShape()
    faces = list(sewn.Faces)
    base = write_shape(tmp_path / "base.brep", faces)
    bumped = patches([(4, 0.02)])[4]
    edited = write_shape(tmp_path / "edited.brep", faces[:4] + [bumped] + faces[5:])
    store = str(tmp_path / "store")
    kw = dict(lref=4.0, jobs=1)
    cold = api.assess(base, cache=store, **kw)
    assert cold.provenance["cache"]["display_meshes_from_store"] == {"hits": 0, "misses": 9}
    warm = api.assess(base, cache=store, **kw)
    assert warm.provenance["cache"]["display_meshes_from_store"] == {"hits": 9, "misses": 0}
    for x, y in zip(_fields(warm), _fields(cold)):
        assert x.shape == y.shape and np.array_equal(x, y, equal_nan=True)
    inc = api.assess(edited, cache=store, **kw)
    fresh = api.assess(edited, cache=False, **kw)
    assert 1 < inc.provenance["cache"]["display_meshes_from_store"]["misses"] < 9  # it and its neighbours
    for x, y in zip(_fields(inc), _fields(fresh)):
        assert x.shape == y.shape and np.array_equal(x, y, equal_nan=True)
    assert inc.signature == fresh.signature


@needs_freecad
def test_faces_sharing_edges_are_neighbours():
    from hullprod_wb.freecad_env import import_freecad
    import_freecad()
    import Part
    from hullprod_wb.brep.reading.record_reader import edge_neighbours
    box = Part.makeBox(1, 1, 1)
    n = edge_neighbours(box.Faces)
    assert [len(x) for x in n] == [4] * 6 and all(k not in x for k, x in enumerate(n))
    assert edge_neighbours([f.copy() for f in box.Faces]) == [[] for _ in range(6)]  # copies share nothing
