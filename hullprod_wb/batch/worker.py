"""What a worker does with one case: assess it and return a plain, picklable record.

run_case is a top-level function so that a process pool and a Dask cluster can both call
it by reference (workers import hullprod_wb). Every failure of a case becomes an error
record; nothing a case does can stop the batch.
"""
import contextlib
import os
import platform
import shutil
import tempfile
import threading
import time
import traceback

from .cases import Case
from .table import make_row

#: FreeCAD documents and OpenCascade are not thread-safe: a worker process with several
#: threads (a Dask worker started with --nthreads > 1) runs its cases one at a time.
_CASE_LOCK = threading.Lock()


def worker_init():
    """Process-pool initializer: load FreeCAD once per worker (absent FreeCAD is not an error)."""
    from ..freecad_env import FreeCADUnavailable, import_freecad
    try:
        import_freecad()
    except FreeCADUnavailable:
        pass


def assess_options(settings):
    """Keyword arguments of assess() for the batch settings (fields are not computed)."""
    opts = {k: settings[k] for k in ("order", "rtol", "max_depth") if settings.get(k) is not None}
    opts.update(settings.get("extra") or {})
    return dict(lref=settings.get("lref"), h_f=settings["h_f"], k_f=settings["k_f"],
                backend=settings.get("backend"), faces=settings.get("faces"), with_fields=False, **opts)


def _replace_strings(obj, old, new):
    """obj with every occurrence of the text old replaced by new in its strings (recursively)."""
    if isinstance(obj, str):
        return obj.replace(old, new)
    if isinstance(obj, dict):
        return {k: _replace_strings(v, old, new) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_replace_strings(v, old, new) for v in obj]
    return obj


def _local_copy(case, payload, tmpdir):
    """Path at which this worker reads the case input.

    The original path when it exists here with the expected content; otherwise payload
    (the file's bytes, shipped by the client) written under the same file name in tmpdir.
    """
    from ..core.inputs import sha256_file
    if os.path.isfile(case.path) and (payload is None or sha256_file(case.path) == case.sha256):
        return case.path
    if payload is None:
        raise FileNotFoundError("input %s is not readable on worker %s and was not shipped"
                                % (case.path, platform.node()))
    path = os.path.join(tmpdir, os.path.basename(case.path))
    with open(path, "wb") as fh:
        fh.write(payload)
    return path


def _assess_case(case, settings, path):
    """(assessment document, assessed object name) of a case read from path."""
    from ..api import assess
    opts = assess_options(settings)
    if case.kind == "file":
        return assess(path, **opts).to_dict(), None
    from .parametric import variant_object
    with variant_object(path, case.params, settings.get("object")) as obj:
        source = obj if hasattr(obj, "Shape") else obj.Mesh
        return assess(source, **opts).to_dict(), obj.Name


class CaseTimeout(Exception):
    """A case that ran longer than the batch's case_timeout."""


#: Seconds after the case_timeout at which a worker process whose case is stuck outside
#: Python (in the geometry kernel, where the timeout signal cannot stop it) ends itself;
#: the pool then records the case as a crash.
HARD_TIMEOUT_GRACE = 30.0


@contextlib.contextmanager
def case_time_limit(seconds):
    """Raise CaseTimeout in the block after seconds (None: no limit). The limit is a
    SIGALRM timer where this is the main thread (this process, a local pool worker; a Dask
    worker's thread runs without one); in a worker process a watchdog thread ends the
    process HARD_TIMEOUT_GRACE seconds later if the case is stuck in code the signal
    cannot interrupt."""
    if not seconds or threading.current_thread() is not threading.main_thread():
        yield
        return
    import multiprocessing
    import signal

    def expire(signum, frame):
        raise CaseTimeout("the case took longer than --case-timeout %g s and was stopped" % seconds)

    previous = signal.signal(signal.SIGALRM, expire)
    done = threading.Event()
    if multiprocessing.parent_process() is not None:
        def watchdog():
            if not done.wait(seconds + HARD_TIMEOUT_GRACE):
                os._exit(70)
        threading.Thread(target=watchdog, daemon=True).start()
    signal.setitimer(signal.ITIMER_REAL, float(seconds))
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)
        done.set()


def run_case(case, settings, settings_hash, payload=None):
    """Assess one case; return its record (dict).

    case: Case or its dict; settings: the batch settings (cases.make_settings);
    payload: the input file's bytes when the worker may not see the path (Dask).
    Record keys: case, settings, settings_hash, status ('ok' | 'error'), error (None or
    {type, message, traceback}), row (table row), assessment (JSON document or None),
    runtime_s, worker, finished_at. settings['case_timeout'] (seconds, None: none): the
    case's time limit (case_time_limit); a case that exceeds it is an error record.
    """
    if isinstance(case, dict):
        case = Case.from_dict(case)
    t0 = time.perf_counter()
    doc, error, obj_name = None, None, None
    tmpdir = tempfile.mkdtemp(prefix="hullprod-batch-")
    try:
        with _CASE_LOCK, case_time_limit(settings.get("case_timeout")):
            path = _local_copy(case, payload, tmpdir)
            doc, obj_name = _assess_case(case, settings, path)
            if path != case.path:  # report the input under its own path, not the worker's copy
                doc = _replace_strings(doc, path, case.path)
    except Exception as exc:  # a failing case is recorded, never raised
        message = " ".join(str(exc).split()) or type(exc).__name__
        if payload is not None:
            message = message.replace(tmpdir + os.sep, os.path.dirname(case.path) + os.sep)
        error = {"type": type(exc).__name__, "message": message, "traceback": traceback.format_exc()}
    finally:
        shutil.rmtree(tmpdir, ignore_errors=True)
    runtime = time.perf_counter() - t0
    err_text = None if error is None else "%s: %s" % (error["type"], error["message"])
    row = make_row(case, settings_hash, doc, err_text, runtime, obj_name, settings.get("case_timeout"))
    return {"case": case.to_dict(), "settings": settings, "settings_hash": settings_hash,
            "status": row["status"], "error": error, "row": row, "assessment": doc,
            "runtime_s": runtime, "worker": "%s:%d" % (platform.node(), os.getpid()),
            "finished_at": time.strftime("%Y-%m-%dT%H:%M:%S%z")}


def crash_record(case, settings, settings_hash, message, kind="WorkerCrash"):
    """Error record of a case that could not report itself (its worker died, or the task
    failed outside run_case); kind names the failure in the error column."""
    error = {"type": kind, "message": message, "traceback": None}
    row = make_row(case, settings_hash, None, "%s: %s" % (kind, message), None, None, settings.get("case_timeout"))
    return {"case": case.to_dict(), "settings": settings, "settings_hash": settings_hash, "status": "error",
            "error": error, "row": row, "assessment": None, "runtime_s": None, "worker": None,
            "finished_at": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
