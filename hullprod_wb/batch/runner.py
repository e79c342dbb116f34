"""Where cases run: in this process, in a local process pool, or on a Dask cluster.

Each runner is a generator ``run(cases) -> records`` yielding one record per case (see
worker.run_case) in completion order. All three call the same worker.run_case, so a case
gives the same numbers wherever it runs.

Local pool: concurrent.futures.ProcessPoolExecutor with the 'spawn' start method by
default (a fresh interpreter per worker; 'forkserver' and 'fork' also work with FreeCAD
on Linux; 'fork' is used only from a process with no thread besides its own, since a
child of a process whose OpenCascade has started threads can wait forever, and 'spawn'
is used instead elsewhere). Each worker reads its BRep files in reading processes of its
own (brep.reading.reader_process), so a file that ends OpenCascade's reader gives an error row. At most 2 x workers cases are in
flight; a worker that dies (a crash in the geometry kernel) breaks the pool, and the
cases then in flight are rerun one at a time in a fresh single-worker pool, so the
culprit is recorded as an error and the others complete.

Dask: dask.distributed.Client(address); cases are submitted as run_case tasks with the
input file's bytes scattered alongside, so workers need not share a file system.
"""
import collections
import contextlib
import multiprocessing
import os
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool

from ..core import runtime
from ..core.errors import InputError
from ..core.processes import available_cpus
from .worker import crash_record, run_case, worker_init

START_METHODS = ("spawn", "forkserver", "fork")


CRASH_MESSAGE = ("the worker process died while assessing this case (a crash in the geometry "
                 "kernel or out of memory); it was isolated by rerunning it alone")


def default_workers():
    """Number of local worker processes by default: the CPUs this process may run on."""
    return available_cpus()


def run_serial(cases, settings, settings_hash):
    """Run cases one after another in this process."""
    for case in cases:
        yield run_case(case, settings, settings_hash)


def pin_package_path():
    """Put the folder holding this hullprod_wb first on sys.path.

    Child processes ('spawn', 'forkserver', Dask's nanny) start with a copy of sys.path,
    and importing FreeCAD puts its Mod folders (possibly another HullProd checkout linked
    there) in front; pinning makes every worker import the same package as this process.
    """
    import sys
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    if not sys.path or sys.path[0] != root:
        sys.path.insert(0, root)


def worker_environment(base=None):
    """The environment local worker processes start with: the runtime settings (core.runtime)
    where base (default os.environ) does not set them, and runtime.BATCH_WORKER over all."""
    env = runtime.environment(base)
    env.update(runtime.BATCH_WORKER)
    return env


@contextlib.contextmanager
def worker_environ():
    """os.environ as worker_environment() while worker processes start (restored afterwards)."""
    wanted = {k: v for k, v in worker_environment().items() if os.environ.get(k) != v}
    saved = {k: os.environ.get(k) for k in wanted}
    os.environ.update(wanted)
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _pool(workers, start_method):
    from ..core.processes import fork_is_clean
    if start_method == "fork" and not fork_is_clean():
        start_method = "spawn"
    pin_package_path()
    return ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context(start_method),
                               initializer=worker_init)


def _terminate_workers(pool):
    """Terminate the worker processes this pool started (each by its own handle)."""
    for proc in list((getattr(pool, "_processes", None) or {}).values()):
        if proc.is_alive():
            proc.terminate()


def _run_alone(case, settings, settings_hash, start_method):
    """Run one case in its own single-worker pool; a crash becomes an error record."""
    pool = _pool(1, start_method)
    finished = False
    try:
        try:
            record = pool.submit(run_case, case, settings, settings_hash).result()
        except BrokenProcessPool:
            record = crash_record(case, settings, settings_hash, CRASH_MESSAGE)
        finished = True
        return record
    finally:
        if not finished:
            _terminate_workers(pool)
        pool.shutdown(wait=True, cancel_futures=True)


def run_local(cases, settings, settings_hash, workers=None, start_method="spawn"):
    """Run cases in a pool of `workers` processes (default: the available CPUs), each started
    with worker_environment()."""
    workers = default_workers() if workers is None else int(workers)
    if workers < 1:
        raise InputError("--workers must be at least 1, got %d" % workers)
    if start_method not in START_METHODS:
        raise InputError("start method must be one of %s, got %r" % (", ".join(START_METHODS), start_method))
    with worker_environ():
        yield from _run_pools(cases, settings, settings_hash, workers, start_method)


def _run_pools(cases, settings, settings_hash, workers, start_method):
    """run_local's loop: a pool of workers, and single-worker pools for crash suspects."""
    pending = collections.deque(cases)
    suspects = collections.deque()
    while pending or suspects:
        while suspects:
            yield _run_alone(suspects.popleft(), settings, settings_hash, start_method)
        if not pending:
            break
        pool = _pool(min(workers, len(pending)), start_method)
        inflight = {}
        try:
            while pending or inflight:
                broken = False
                while pending and len(inflight) < 2 * workers:
                    case = pending.popleft()
                    try:
                        inflight[pool.submit(run_case, case, settings, settings_hash)] = case
                    except BrokenProcessPool:  # a worker died since the last results: not run
                        pending.appendleft(case)
                        broken = True
                        break
                done = set() if broken else wait(inflight, return_when=FIRST_COMPLETED)[0]
                for fut in done:
                    try:
                        record = fut.result()
                    except BrokenProcessPool:
                        broken = True
                        continue
                    except Exception as exc:  # the task could not run (e.g. its arguments failed to unpickle)
                        record = crash_record(inflight[fut], settings, settings_hash,
                                              "%s: %s" % (type(exc).__name__, exc), "TaskError")
                    del inflight[fut]
                    yield record
                if broken:
                    for fut, case in list(inflight.items()):
                        if fut.done() and not fut.cancelled() and fut.exception() is None:
                            yield fut.result()
                        else:
                            suspects.append(case)
                    inflight.clear()
                    break
        finally:
            if inflight:  # interrupted (Ctrl-C, or the caller stopped early): do not wait for running cases
                for fut in inflight:
                    fut.cancel()
                _terminate_workers(pool)
            pool.shutdown(wait=True, cancel_futures=True)


def connect(address, timeout=30):
    """dask.distributed.Client connected to the scheduler at address, with at least one worker."""
    try:
        from dask.distributed import Client
    except ImportError as exc:
        raise InputError("--scheduler needs dask.distributed (Debian: python3-distributed): %s" % exc) from None
    try:
        client = Client(address, timeout=timeout)
    except (OSError, TimeoutError) as exc:
        raise InputError("cannot reach the Dask scheduler at %s: %s" % (address, exc)) from None
    try:
        client.wait_for_workers(1, timeout=timeout)
    except (TimeoutError, OSError) as exc:
        client.close()
        raise InputError("the Dask scheduler at %s has no worker (%s)" % (address, exc)) from None
    return client


def _payload(case):
    with open(case.path, "rb") as fh:
        return fh.read()


def run_dask(cases, settings, settings_hash, scheduler):
    """Run cases on a Dask cluster: scheduler is an address ('tcp://host:8786') or a Client.

    The input bytes of each file are scattered once (documents once for all their
    variants); at most 2 x (worker threads) cases are in flight.
    """
    from dask.distributed import as_completed
    own = isinstance(scheduler, str)
    client = connect(scheduler) if own else scheduler
    inflight = {}  # task key -> (case, future)
    try:
        slots = 2 * max(1, sum(w.get("nthreads", 1) for w in client.scheduler_info()["workers"].values()))
        pending = collections.deque(cases)
        remaining = collections.Counter(c.path for c in cases)
        scattered = {}
        ac = as_completed()

        def submit():
            case = pending.popleft()
            if case.path not in scattered:
                scattered[case.path] = client.scatter(_payload(case), hash=False)
            fut = client.submit(run_case, case, settings, settings_hash, scattered[case.path], pure=False,
                                key="hullprod-%s-%s" % (case.case_id, os.urandom(4).hex()))
            inflight[fut.key] = (case, fut)
            ac.add(fut)

        while pending and len(inflight) < slots:
            submit()
        for fut in ac:
            case, _ = inflight.pop(fut.key)
            try:
                record = fut.result()
            except Exception as exc:  # the task itself failed: e.g. KilledWorker after repeated crashes
                kind = "WorkerCrash" if type(exc).__name__ == "KilledWorker" else "TaskError"
                record = crash_record(case, settings, settings_hash, "%s: %s" % (type(exc).__name__, exc), kind)
            fut.release()
            remaining[case.path] -= 1
            if remaining[case.path] == 0:
                scattered.pop(case.path).release()
            yield record
            if pending:
                submit()
    finally:
        if inflight:  # interrupted: withdraw the cases still queued or running on the cluster
            client.cancel([f for _, f in inflight.values()])
        if own:
            client.close()
