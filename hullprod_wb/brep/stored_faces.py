"""A pass over faces through the faces' store: each face from the store where its key hits,
else assessed here and stored; a face another run is assessing (its key claimed, see
core.result_claims) is awaited after this run's own faces instead of assessed twice.

The store holds a result under the key of everything it depends on (brep.face_keys): a
result the point budget bound under its exact key, one it never bound under its free key,
taken for every budget it fits (face_result.FaceAssessment.fits). So a face taken from the
store, awaited or assessed here is the same to the bit.
"""
import os
import time

from ..core.processes import map_faces
from .face_result import FaceAssessment

#: What a worker returns for a face whose key another run holds (or whose entry appeared).
AWAITED = "awaited"
#: Seconds between looks at the store while awaiting other runs' faces (doubling to POLL_MAX_S).
POLL_S = 0.02
POLL_MAX_S = 0.5


def stored_or_assessed(run, todo, cost, while_waiting=None, beside=False):
    """The results of the faces todo (indices of run.shape.faces): from run.store where their
    keys (run.key) hit, the others assessed (run.face_work) in run.n_jobs processes and
    stored as they finish; while_waiting and beside as map_faces's. This process's seconds in the
    store (keys, lookups, writes, claims) are added to run.timings["store_s"]."""
    store, faces = run.store, run.shape.faces
    out, missed = [None] * len(todo), []
    with run.timed("store_s"):
        keys = [run.key(i) for i in todo]
        for k, (i, key) in enumerate(zip(todo, keys)):
            f = look_up(store, key) if key is not None else None
            if f is None:
                missed.append(k)
            else:
                out[k] = _taken(run, i, f)

    def work(m):  # in a worker process: the face, unless another run is making it
        key = keys[missed[m]]
        if key is not None and (not store.claim(key.claim) or _stored(store, key)):
            return AWAITED
        return run.face_work(todo[missed[m]])

    awaited, released = [], set()

    def done(m, f):  # stored as it comes, while the other faces are integrated
        k = missed[m]
        if isinstance(f, str):
            awaited.append(k)
            return
        if keys[k] is not None:
            with run.timed("store_s"):
                if isinstance(f, FaceAssessment):
                    store.put(keys[k].free if keys[k].free and f.fits(keys[k].budget) else keys[k].exact, f)
                store.release(keys[k].claim)
                released.add(k)
        run.finished(todo[k], f)

    try:
        got = map_faces(work, len(missed), run.n_jobs, cost=[cost[todo[k]] for k in missed],
                        labels=["Face%d" % faces[todo[k]][0] for k in missed], on_done=done,
                        while_waiting=while_waiting, beside=beside)
    finally:  # the claims of faces not stored (awaited, failed or interrupted)
        with run.timed("store_s"):
            for k in missed:
                if keys[k] is not None and k not in released:
                    store.release(keys[k].claim)
    for k, f in zip(missed, got):
        if not isinstance(f, str):
            out[k] = f
    if awaited:
        _await(run, sorted(awaited), todo, keys, cost, out)
    return out


def look_up(store, keys):
    """The stored result of a face of keys (face_keys.FaceKeys): under the exact key, else
    under the free key where it fits the budget (made its point budgets), else None (one
    hit or one miss counted)."""
    f = store.get(keys.exact, count_miss=keys.free is None)
    if f is None and keys.free is not None:
        f = store.get(keys.free, accept=lambda g: g.fits(keys.budget))
        if f is not None:
            f.with_budget(keys.budget)
    return f


def _stored(store, keys):
    """Whether look_up would find the face's result (nothing counted)."""
    return store.holds(keys.exact) or (keys.free is not None
                                       and store.holds(keys.free, lambda g: g.fits(keys.budget)))


def _taken(run, i, f):
    """Face i's result f from the store, renumbered and reported."""
    number = run.shape.faces[i][0]
    f = f.renumbered(number)
    run.from_store.append(number)
    run.finished(i, f, "from the store")
    return f


def _await(run, awaited, todo, keys, cost, out):
    """Fill out[k] for k in awaited (faces other runs claimed): each from the store once its
    entry is there; a face whose claim ended without an entry (the run failed or could not
    write) is assessed here."""
    store, pending, pause = run.store, list(awaited), POLL_S
    run.progress(run.pass_fraction(run.done_weight), "waiting for %d face(s) another run is integrating"
                 % len(pending))
    while pending:
        left, orphans = [], []
        for k in pending:
            f = look_up(store, keys[k]) if _stored(store, keys[k]) else None
            if f is not None:
                store.counts.awaited += 1
                out[k] = _taken(run, todo[k], f)
            elif store.claimed_elsewhere(keys[k].claim):
                left.append(k)
            else:
                orphans.append(k)
        if orphans:
            for k, f in zip(orphans, stored_or_assessed(run, [todo[k] for k in orphans], cost)):
                out[k] = f
        pending = left
        if pending:
            time.sleep(pause)
            pause = min(2 * pause, POLL_MAX_S)
