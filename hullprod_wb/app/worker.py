"""The assessment process of the workbench: `python3 -m hullprod_wb.app.worker`.

The GUI starts it as a fresh interpreter (never a fork of FreeCAD's process) and talks to
it in JSON lines: requests on stdin, events on stdout.

Requests:
  {"op": "load", "kind": "brep" | "mesh", "path": ..., "faces": [...] | null}
      the input written by the GUI: a BRep file of the shape (Part.Shape.exportBrepToString)
      or an .npz of the mesh's vertices and triangles. Answered by
      {"event": "loaded", "lref": automatic L_ref of the faces, "lref_whole": of the whole
      shape} computed by the same functions as the run's automatic L_ref.
  {"op": "run", "options": {...}, "result": path}
      api.assess of the loaded input with these keyword arguments, exactly as
      `./hullprod analyze` runs it (faces in parallel processes); events
      {"event": "progress", "fraction": f, "message": m}, then {"event": "done"} with the
      pickled Assessment written to path (with the run's seconds, its face processes
      "jobs", the process's threads when it started, and the assessment's timings), or {"event": "error", "kind": "input" | "internal",
      "message": ...}. The process then exits.
  {"op": "study", "study": kind, "options": {...}, "result": path}
      a verification study of the loaded input (app.study_run.run_study), with progress
      events like a run; its JSON-safe document is pickled to path. The process then exits.
  A load with "propose": false skips the L_ref proposal ("loaded" carries nulls).

Nothing here imports FreeCADGui or Qt; FreeCAD itself is only loaded in a forked child
(the L_ref proposal) or by the backend's own file reader, as in the command line.
"""
import json
import os
import pickle
import sys
import time
import traceback

#: Least time between two progress events (seconds); the last message always goes out.
PROGRESS_INTERVAL = 0.05


def emit(event, **data):
    """One event line on stdout."""
    data["event"] = event
    sys.stdout.write(json.dumps(data, allow_nan=True) + "\n")
    sys.stdout.flush()


class Progress:
    """progress(fraction, message) of the backends, sent as events at most every
    PROGRESS_INTERVAL seconds (a new message always)."""

    def __init__(self):
        self.last, self.message = 0.0, None

    def __call__(self, fraction, message=""):
        now = time.monotonic()
        if message != self.message or now - self.last >= PROGRESS_INTERVAL:
            self.last, self.message = now, message
            emit("progress", fraction=float(fraction), message=str(message))


def brep_lref(path, faces):
    """(automatic L_ref of the faces, of the whole shape) of a BRep file, by the backend's
    method (brep.display.tessellation_samples at lref_samples.SAMPLE_DEFLECTION of the
    shape's bounding-box diagonal, then core.reference_length); None where not sampled."""
    from ..brep.display import tessellation_samples
    from ..brep.reading.loading import load_brep
    from ..brep.reading.lref_samples import SAMPLE_DEFLECTION
    from ..core.reference_length import automatic_length
    inp = load_brep(path, faces)
    size = inp.shape.BoundBox.DiagonalLength  # before anything is tessellated (provenance.shape_boxes)

    def span(chosen):
        s = tessellation_samples([f for _, f in chosen], SAMPLE_DEFLECTION * size)
        return None if s is None else float(automatic_length(s["points"], s["triangles"], s["node_area"]))
    chosen = span(inp.faces)
    whole = chosen if faces is None else span(list(enumerate(inp.shape.Faces, 1)))
    return chosen, whole


def mesh_lref(path):
    """Automatic L_ref of a mesh .npz, by the mesh backend's method (core.reference_length
    on the prepared mesh)."""
    import numpy as np
    from ..core.reference_length import automatic_length
    from ..mesh.backend import open_mesh
    data = np.load(path)
    mesh, _ = open_mesh((data["vertices"], data["faces"]))
    value = float(automatic_length(np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64)))
    return value, value


def load_proposal(kind, path, faces):
    """The 'loaded' event's values, computed in a forked child for a BRep (FreeCAD is
    loaded there only, so the run itself starts as the command line's does)."""
    if kind == "mesh":
        return mesh_lref(path)
    from ..core.processes import ForkedCall
    from ..freecad_env import import_freecad

    def compute():
        import_freecad()
        return brep_lref(path, faces)
    call = ForkedCall(compute)
    # meanwhile this process loads what the run needs, as the command line's does
    from .. import api  # noqa: F401
    from ..brep import backend  # noqa: F401
    return call.result()


def assess(kind, path, faces, options):
    """api.assess of the loaded input (a BRep file path, or the mesh's arrays)."""
    from .. import api
    if kind == "mesh":
        import numpy as np
        data = np.load(path)
        return api.assess((data["vertices"], data["faces"]), **options)
    return api.assess(path, faces=faces, **options)


def run_study_request(loaded, req):
    """A study of the loaded input (app.study_run), its document pickled to req["result"]."""
    from .study_run import run_study
    kind, path, faces = loaded
    source = path
    if kind == "mesh":
        import numpy as np
        data = np.load(path)
        source = (data["vertices"], data["faces"])
    t = time.perf_counter()
    doc = run_study(req["study"], source, faces, req.get("options") or {}, Progress())
    seconds = time.perf_counter() - t
    with open(req["result"], "wb") as fh:
        pickle.dump(doc, fh, pickle.HIGHEST_PROTOCOL)
    emit("done", seconds=seconds)


def read_request():
    line = sys.stdin.readline()
    if not line:
        return None
    return json.loads(line)


def main():
    from ..core.errors import InputError
    emit("ready", pid=os.getpid())
    loaded = None
    while True:
        req = read_request()
        if req is None:
            return 0
        try:
            if req["op"] == "load":
                loaded = (req["kind"], req["path"], req.get("faces"))
                lref, whole = load_proposal(*loaded) if req.get("propose", True) else (None, None)
                emit("loaded", lref=lref, lref_whole=whole)
            elif req["op"] == "study":
                if loaded is None:
                    raise InputError("nothing was loaded to study")
                run_study_request(loaded, req)
                return 0
            elif req["op"] == "run":
                if loaded is None:
                    raise InputError("nothing was loaded to assess")
                options = dict(req.get("options") or {}, progress=Progress())
                from ..core.processes import thread_count
                threads = thread_count()
                t = time.perf_counter()
                result = assess(*loaded, options)
                seconds = time.perf_counter() - t
                with open(req["result"], "wb") as fh:
                    pickle.dump(result, fh, pickle.HIGHEST_PROTOCOL)
                emit("done", seconds=seconds, jobs=(result.options or {}).get("jobs"),
                     threads_at_start=threads, timings=dict(result.timings or {}))
                return 0
        except InputError as exc:
            emit("error", kind="input", message=" ".join(str(exc).split()))
            if req.get("op") in ("run", "study"):
                return 2
        except Exception as exc:
            emit("error", kind="internal", message="%s: %s" % (type(exc).__name__, exc),
                 traceback=traceback.format_exc())
            if req.get("op") in ("run", "study"):
                return 1


if __name__ == "__main__":
    sys.exit(main())
