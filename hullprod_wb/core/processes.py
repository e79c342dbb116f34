"""Process helpers: faces of a BRep assessment integrated in parallel worker processes, forked
single calls, whether forking is safe here, and the one count of the CPUs (available_cpus).

The faces of a shape are integrated independently of each other (face_assessment.assess_face: one
face's adaptive tree never looks at another's), so running them in several processes gives
the same numbers, to the bit, as running them one after the other; only the wall time
changes. Workers are forked from the assessing process and inherit the shape that is
already loaded (no file is read twice and no OpenCascade object is pickled); each returns
its face's record as plain data. Faces are handed out largest first (by their number of
surface patches), so the longest face does not start last.

A face assessed alone is integrated in patch groups instead (cubature.patch_groups), which
map_forked shares between this process and children forked from it once the face's field
and trimmed domain are built; ForkedCall is one such child, for any work on state this
process has built.

Forking is used only where it is safe: Linux, called from the main thread of a process that
has no other thread (fork_is_clean), is not itself a pool worker, and not inside the FreeCAD
GUI (its render and Qt threads). A second thread means state a child would inherit without
the thread that owns it: OpenCascade's thread pool once anything has meshed in parallel
(FreeCAD 1.x meshes so; a child that meshes again waits forever), BLAS threads, a GUI. It is
checked again at every fork, so a process that meshes between two assessments stops
forking. Elsewhere, and with jobs=1, the faces run in this process with progress inside
each face.
"""
import os
import pickle
import sys
import threading

from .errors import InputError

#: Environment variable that sets the automatic number of worker processes (batch workers
#: set it to 1: they already run one case per CPU).
JOBS_ENV = "HULLPROD_JOBS"

# the work of the running map, set in the parent before its workers are forked
_WORK = None


def thread_count():
    """Threads of this process as the kernel counts them (those Python did not start too:
    OpenCascade's, BLAS's, Qt's), or None where /proc does not tell."""
    try:
        with open("/proc/self/stat", "rb") as fh:
            return int(fh.read().rsplit(b")", 1)[1].split()[17])
    except (OSError, IndexError, ValueError):
        return None


def other_threads():
    """Kernel ids of this process's threads but the calling one, or None where /proc does
    not tell."""
    try:
        tids = {int(tid) for tid in os.listdir("/proc/self/task")}
    except (OSError, ValueError):
        return None
    tids.discard(threading.get_native_id())
    return tids


#: Seconds fork_is_clean waits for the kernel to let go of threads Python has seen end (a
#: joined thread returns from join a moment before its kernel thread has gone).
SETTLE_SECONDS = 0.2
#: Kernel threads that outlasted such a wait: not Python's (OpenCascade's, BLAS's, Qt's).
_LASTING = set()


def fork_is_clean():
    """True where a process forked from this one starts clean: Linux, the main thread, and
    no other thread in the process (see module doc). Kernel threads of Python threads that
    have ended are waited for (SETTLE_SECONDS at most); one still there after that is
    another library's and counts."""
    if not sys.platform.startswith("linux") or not hasattr(os, "fork"):  # macOS: system
        return False                                                      # frameworks are not fork-safe
    if threading.current_thread() is not threading.main_thread() or threading.active_count() > 1:
        return False
    others = other_threads()
    if others is None:
        return False
    import time
    end = time.monotonic() + SETTLE_SECONDS
    while others and not others & _LASTING and time.monotonic() < end:
        time.sleep(0.0005)
        others = other_threads()
    _LASTING.update(others)
    return not others


def fork_is_safe():
    """True where worker processes may be forked from this process (see module doc)."""
    if not fork_is_clean():
        return False
    # a daemonic multiprocessing worker (a batch pool's) may not have children; a process
    # that has not imported multiprocessing is none (and need not import it)
    mp = sys.modules.get("multiprocessing")
    if mp is not None and mp.current_process().daemon:
        return False
    try:
        FreeCAD = sys.modules.get("FreeCAD")
        if FreeCAD is not None and getattr(FreeCAD, "GuiUp", False):
            return False
    except Exception:  # a half-initialised FreeCAD: do not fork
        return False
    return True


def available_cpus():
    """CPUs this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def resolve_jobs(jobs, n_faces):
    """Worker processes for n_faces faces: jobs (an int >= 1), or None for automatic (the
    value of $HULLPROD_JOBS if set, else the available CPUs; 1 where forking is not safe),
    never more than the faces. Returns an int >= 1."""
    if jobs is None:
        env = os.environ.get(JOBS_ENV, "").strip()
        if env:
            try:
                jobs = int(env)
            except ValueError:
                raise InputError("%s must be a positive integer, got %r" % (JOBS_ENV, env)) from None
    if jobs is not None:
        try:
            jobs = int(jobs)
        except (TypeError, ValueError):
            raise InputError("jobs must be a positive integer, got %r" % (jobs,)) from None
        if jobs < 1:
            raise InputError("jobs must be a positive integer, got %r" % (jobs,))
    if n_faces <= 1 or jobs == 1 or not fork_is_safe():
        return 1
    return max(1, min(available_cpus() if jobs is None else jobs, n_faces))


def second_process_allowed(jobs=None):
    """Whether work may go to a second process beside this one: forking is safe here and
    jobs (resolve_jobs; None: automatic) allows more than one process."""
    return fork_is_safe() and resolve_jobs(jobs, 2) > 1


def _run_one(index):
    return _WORK(index)


def map_faces(work, n, jobs, cost=None, on_done=None, labels=None, while_waiting=None, beside=False):
    """[work(0), ..., work(n - 1)] with jobs worker processes (resolve_jobs first; at most
    n of them).

    work(i) returns a picklable result; cost (n,) orders the hand-out (largest first);
    on_done(i, result) is called in this process as each finishes; while_waiting() is
    called once in this process, while the workers run (first, without workers; so too
    where forking has stopped being safe since jobs was resolved). beside: a single item
    goes to a worker too (with jobs > 1), so that while_waiting runs beside it. An error
    raised by work is raised here; a worker that dies (a crash in the geometry kernel) is
    reported as an InputError naming the items (labels, default their indices) that were
    still running."""
    global _WORK
    results = [None] * n
    if jobs <= 1 or n < 1 or (n == 1 and not beside) or not fork_is_safe():
        if while_waiting is not None:
            while_waiting()
        for i in range(n):
            results[i] = work(i)
            if on_done is not None:
                on_done(i, results[i])
        return results
    import multiprocessing
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool
    order = sorted(range(n), key=lambda i: -(cost[i] if cost is not None else 0.0))
    _WORK = work
    try:
        with ProcessPoolExecutor(max_workers=min(jobs, n), mp_context=multiprocessing.get_context("fork")) as pool:
            pending = {pool.submit(_run_one, i): i for i in order}
            try:
                if while_waiting is not None:
                    while_waiting()
                while pending:
                    done, _ = wait(pending, return_when=FIRST_COMPLETED)
                    for fut in done:
                        i = pending.pop(fut)
                        try:
                            results[i] = fut.result()
                        except BrokenProcessPool:
                            left = sorted([i] + list(pending.values()))
                            raise InputError(
                                "a worker process died while integrating %s (a crash in the "
                                "geometry kernel or out of memory); run with jobs=1 to see it"
                                % ", ".join(str(labels[k] if labels else k) for k in left)) from None
                        if on_done is not None:
                            on_done(i, results[i])
            except BaseException:
                for fut in pending:
                    fut.cancel()
                raise
    finally:
        _WORK = None
    return results


def reap(pid):
    """Stop (if still running) and wait for the child process pid."""
    try:
        os.kill(pid, 9)
    except OSError:
        pass
    try:
        os.waitpid(pid, 0)
    except ChildProcessError:
        pass


class ForkedCall:
    """fn() computed in a child forked now (with fork, where fork_is_safe), for work on
    state this process has built. result() returns its value, pickled through a pipe, or
    computes it here when the child died before sending (a crash in the geometry kernel,
    memory) or nothing was forked: the same value either way; an exception raised by fn is
    raised by result(). close() stops and reaps a child whose result is not wanted."""

    def __init__(self, fn, fork=True):
        self.fn = fn
        self.pid, self._fd = None, None
        self._done, self._value = False, None
        if fork and fork_is_safe():
            r, w = os.pipe()
            pid = os.fork()
            if pid == 0:  # child: compute, send, leave without the parent's exit handlers
                os.close(r)
                try:
                    try:
                        data = pickle.dumps((True, fn()), pickle.HIGHEST_PROTOCOL)
                    except BaseException as exc:  # sent to the parent, raised there
                        data = pickle.dumps((False, exc), pickle.HIGHEST_PROTOCOL)
                    with os.fdopen(w, "wb") as fh:
                        fh.write(data)
                finally:
                    os._exit(0)
            os.close(w)
            self.pid, self._fd = pid, r

    def result(self):
        if not self._done:
            data = b""
            if self.pid is not None:
                with os.fdopen(self._fd, "rb") as fh:
                    data = fh.read()
                self._fd = None
                reap(self.pid)
                self.pid = None
            if data:
                ok, value = pickle.loads(data)
                if not ok:
                    raise value
            else:
                value = self.fn()
            self._done, self._value = True, value
        return self._value

    def close(self):
        if self.pid is not None:
            reap(self.pid)
            self.pid = None
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None


def map_forked(work, n, jobs, while_waiting=None):
    """[work(0), ..., work(n - 1)] with work(0) in this process and the others in up to
    jobs - 1 children forked from it (ForkedCall), for work on state this process has built
    (a face's field and trimmed domain); items beyond the children run here too. Where
    forking is not safe, with jobs <= 1, or for an item whose child died before sending, the
    item runs here instead: the results are the same either way. while_waiting() is called
    once in this process after its own items, before the children's results are collected
    (last, without children). An exception raised by work is raised here."""
    fork = jobs > 1 and n > 1 and fork_is_safe()
    children = {i: ForkedCall(lambda i=i: work(i)) for i in range(1, min(n, jobs))} if fork else {}
    try:
        results = [None if i in children else work(i) for i in range(n)]
        if while_waiting is not None:
            while_waiting()
        for i, call in children.items():
            results[i] = call.result()
    finally:
        for call in children.values():  # left by an exception: stop and reap the children
            call.close()
    return results
