"""The GUI's side of the assessment process (app.worker): start it, send it the input,
read its events without blocking, cancel it.

The process is a fresh /usr/bin/python3 (never a fork of FreeCAD's process, whose
OpenCascade threads make fork unsafe), in a session of its own, so that cancelling ends it
and the face processes it forked at once. No Qt here: a caller polls (a Qt timer in the
GUI, wait() in a recompute).
"""
import hashlib
import json
import os
import pickle
import select
import shutil
import signal
import subprocess
import sys
import tempfile
import time

from ..core import runtime
from ..core.errors import InputError
from ..core.progress import Cancelled

#: Interpreter of the assessment process: $HULLPROD_PYTHON, else Debian's Python (the one
#: that sees FreeCAD's modules; the command line uses it too).
DEFAULT_PYTHON = "/usr/bin/python3"
PACKAGE_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def worker_environment(base=None):
    """The assessment process's environment: base (default os.environ) without PYTHONHOME,
    with the runtime settings of the command line (core.runtime) where base does not set
    them, and this package's folder first on PYTHONPATH."""
    env = runtime.environment(base)
    env.pop("PYTHONHOME", None)
    env["PYTHONPATH"] = PACKAGE_ROOT + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    return env


def worker_python():
    return os.environ.get("HULLPROD_PYTHON") or (DEFAULT_PYTHON if os.path.isfile(DEFAULT_PYTHON) else
                                                 shutil.which("python3") or sys.executable)


class WorkerFailed(RuntimeError):
    """The assessment process failed inside (a bug) or ended without an answer."""


def _payload(source):
    """(kind, data, record) of a Part or Mesh document object: the shape's BRep text
    (Part.Shape.exportBrepToString, without display triangulations) as bytes, or the mesh's
    placed vertices and triangles; the record names the object and carries the sha256 of
    the data."""
    doc = getattr(source, "Document", None)
    record = {"name": source.Label, "object": source.Name,
              "document": getattr(doc, "FileName", "") or getattr(doc, "Name", "")}
    if hasattr(source, "Shape"):
        shape = source.Shape
        if shape is None or shape.isNull() or not shape.Faces:
            raise InputError("%s has no faces to assess" % source.Label)
        text = shape.copy(True, False).exportBrepToString()
        data = text.encode("latin-1") if isinstance(text, str) else bytes(text)
        record.update(format="freecad-shape", sha256=hashlib.sha256(data).hexdigest(),
                      sha256_of="the shape's BRep text (Part.Shape.exportBrepToString, no triangulation)")
        return "brep", data, record
    import numpy as np
    points, facets = source.Mesh.Topology
    if not len(facets):
        raise InputError("mesh %s has no triangles" % source.Label)
    V = np.array([(p.x, p.y, p.z) for p in points], float).reshape(-1, 3)
    F = np.array(facets, np.int64).reshape(-1, 3)
    record.update(format="FreeCAD mesh", sha256=hashlib.sha256(V.tobytes() + F.tobytes()).hexdigest(),
                  sha256_of="the placed vertices (float64) and triangles (int64) of the mesh")
    return "mesh", (V, F), record


def object_record(source):
    """The input record of a Part or Mesh document object (see _payload)."""
    return _payload(source)[2]


def source_input(source, faces, folder):
    """Write source into folder for the assessment process: (kind, path, input record),
    a Part's shape as a .brep file, a mesh as an .npz (see _payload)."""
    kind, data, record = _payload(source)
    if kind == "brep":
        path = os.path.join(folder, "shape.brep")
        with open(path, "wb") as fh:
            fh.write(data)
    else:
        import numpy as np
        path = os.path.join(folder, "mesh.npz")
        np.savez(path, vertices=data[0], faces=data[1])
    return kind, path, record


class AssessmentProcess:
    """One assessment of one source in its own process.

    Construction starts the process and sends it the input (load). run(options) starts
    the assessment; poll() returns the events that arrived (dicts, app.worker), without
    blocking; cancel() ends the process at once; result() loads the Assessment after a
    'done' event. The process preloads and proposes the automatic L_ref ('loaded') unless
    propose is False. run_study(kind, options) runs a verification study instead, and
    study_result() loads its document.
    """

    def __init__(self, source, faces=None, propose=True):
        self.folder = tempfile.mkdtemp(prefix="hullprod_run_")
        self.label = source.Label
        self.kind, self.input_path, self.record = source_input(source, faces, self.folder)
        self.faces = list(faces) if faces else None
        env = worker_environment()
        self.proc = subprocess.Popen([worker_python(), "-P", "-m", "hullprod_wb.app.worker"], cwd=self.folder,
                                     env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.DEVNULL, start_new_session=True, bufsize=0)
        self._buffer = b""
        self.events = []
        self.state = "loading"  # loading | loaded | running | done | error | cancelled
        self.error = None
        self.lref = self.lref_whole = None
        self.load_error = None
        self.last_progress = None
        self.seconds = None
        self._send({"op": "load", "kind": self.kind, "path": self.input_path, "faces": self.faces,
                    "propose": propose})

    # -- talking -------------------------------------------------------------------------
    def _send(self, request):
        try:
            self.proc.stdin.write((json.dumps(request) + "\n").encode())
            self.proc.stdin.flush()
        except (BrokenPipeError, OSError):
            pass  # the process is gone: poll() reports it

    def run(self, options):
        """Start the assessment with api.assess keyword arguments (no progress)."""
        self.state = "running"
        self.started_at = time.perf_counter()
        self._send({"op": "run", "options": options, "result": os.path.join(self.folder, "result.pickle")})

    def run_study(self, kind, options):
        """Start the study kind (app.study_run) with its options instead of an assessment."""
        self.state = "running"
        self.started_at = time.perf_counter()
        self._send({"op": "study", "study": kind, "options": options,
                    "result": os.path.join(self.folder, "result.pickle")})

    def poll(self, timeout=0.0):
        """Events that arrived within timeout seconds (list of dicts); updates state."""
        out = []
        fd = self.proc.stdout
        if fd.closed:
            return out
        while True:
            ready, _, _ = select.select([fd], [], [], timeout)
            if not ready:
                break
            chunk = os.read(fd.fileno(), 1 << 16)
            if not chunk:
                self._ended()
                break
            self._buffer += chunk
            timeout = 0.0
        while b"\n" in self._buffer:
            line, self._buffer = self._buffer.split(b"\n", 1)
            try:
                ev = json.loads(line)
            except ValueError:
                continue
            self._note(ev)
            out.append(ev)
        if self.state in ("loading", "loaded", "running") and self.proc.poll() is not None and not out:
            self._ended()
        return out

    def _note(self, ev):
        kind = ev.get("event")
        if kind == "progress":
            self.last_progress = (ev.get("fraction"), ev.get("message"))
        elif kind == "loaded":
            self.lref, self.lref_whole = ev.get("lref"), ev.get("lref_whole")
            if self.state == "loading":
                self.state = "loaded"
        elif kind == "done":
            self.state, self.seconds = "done", ev.get("seconds")
            self.done_event = ev
            self.done_at = time.perf_counter()
        elif kind == "error" and self.state == "loading":
            self.load_error = ev.get("message")
            self.state = "loaded"
        elif kind == "error" and self.state == "running":
            self.state = "error"
            self.error = ev

    def _ended(self):
        if self.state in ("loading", "loaded", "running"):
            code = self.proc.wait()
            self.state = "error"
            self.error = {"kind": "internal", "message": "the assessment process of %s ended without an answer "
                          "(exit code %s)" % (self.label, code)}

    def cancel(self):
        """End the process and the processes it started, now."""
        if self.proc.poll() is None:
            try:
                os.killpg(self.proc.pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass
        self.proc.wait()
        if self.state not in ("done", "error"):
            self.state = "cancelled"

    @property
    def finished(self):
        return self.state in ("done", "error", "cancelled")

    def raise_error(self):
        """Raise the failure as InputError (the input's fault) or WorkerFailed (a bug)."""
        ev = self.error or {}
        if ev.get("kind") == "input":
            raise InputError(ev.get("message", "the assessment failed"))
        raise WorkerFailed("%s%s" % (ev.get("message", "the assessment process failed"),
                                     ("\n" + ev["traceback"]) if ev.get("traceback") else ""))

    def result(self):
        """The Assessment of a finished run, its input record naming the FreeCAD object."""
        if self.state != "done":
            self.raise_error()
        with open(os.path.join(self.folder, "result.pickle"), "rb") as fh:
            a = pickle.load(fh)
        describe_object_input(a, self.record)
        return a

    def study_result(self):
        """The study document of a finished run_study, its input naming the FreeCAD object."""
        if self.state != "done":
            self.raise_error()
        with open(os.path.join(self.folder, "result.pickle"), "rb") as fh:
            doc = pickle.load(fh)
        doc["input"] = dict(doc.get("input") or {}, path=None, **self.record)
        return doc

    def wait(self, progress=None, interval=0.1):
        """Block until the run ends, calling progress(fraction, message) at least every
        interval seconds; a Cancelled raised by progress cancels the process and is raised."""
        last = (0.0, "assessing %s" % self.label)
        while not self.finished:
            for ev in self.poll(interval):
                if ev.get("event") == "progress":
                    last = (ev["fraction"], ev["message"])
            if progress is not None:
                try:
                    progress(*last)
                except Cancelled:
                    self.cancel()
                    raise
        return self.result()

    def close(self):
        """End the process if it still runs and remove its folder."""
        if self.proc.poll() is None:
            self.cancel()
        for f in (self.proc.stdin, self.proc.stdout):
            try:
                f.close()
            except OSError:
                pass
        shutil.rmtree(self.folder, ignore_errors=True)


def describe_object_input(assessment, record):
    """The input record of an assessment of a FreeCAD object sent as a file: the object's
    name, document and the sha256 of what was sent, not the temporary file's path."""
    info = assessment.input
    info["path"] = None
    for key, value in record.items():
        info[key] = value
    units = assessment.provenance.get("units")
    if record.get("format") == "freecad-shape" and isinstance(units, dict):
        units.update(source_unit="model units", working_unit="model units (FreeCAD: mm)")
    return assessment


def run_in_process(source, faces, options, progress=None):
    """Assess source in an assessment process and wait (a recompute with the GUI up)."""
    proc = AssessmentProcess(source, faces)
    try:
        proc.run(options)
        return proc.wait(progress)
    finally:
        proc.close()
