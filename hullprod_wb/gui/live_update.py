"""Live analysis: an analysis whose AutoUpdate is on follows its source in the background.

When a recompute finds the source changed and the settings not (app.analysis execute), it
calls start(obj) instead of assessing: an assessment process (app.assessment_process, the
command line's code) assesses the source as it is now, the faces that did not change coming
from the faces' store, while a Qt timer polls it without ever blocking the event loop. When
it is done the result goes into the analysis as the Analyze panel's does (proxy.pending and
a recompute of the analysis alone): the maps, legend and panels update in place, and the
analysis records the change of I_D and the faces integrated anew. A further change of the
source while one runs cancels it and starts again; so does deleting the analysis.
"""
import time

from ..app import analysis as app_analysis
from ..app.analysis import assessed_faces, assessment_options, record_planar
from ..app.assessment_process import AssessmentProcess, WorkerFailed
from ..core.errors import InputError
from .qt import QtCore

#: Milliseconds between polls of a running update.
POLL_MS = 50
#: The running updates: analysis object name -> Update.
RUNNING = {}


class Update:
    """One background reassessment of an analysis obj: its process, its timer, when it began."""

    def __init__(self, obj):
        from .. import api
        self.obj, self.doc, self.name = obj, obj.Document, obj.Name
        rep = api.representation_of(obj.Source)
        faces, self.planar = assessed_faces(obj) if rep == "brep" else (None, [])
        self.proc = AssessmentProcess(obj.Source, faces, propose=False)
        self.proc.run(assessment_options(obj, rep))
        self.started = time.perf_counter()
        self.timer = QtCore.QTimer()
        self.timer.setInterval(POLL_MS)
        self.timer.timeout.connect(self.poll)
        self.timer.start()

    def alive(self):
        """Whether the analysis still exists in its document."""
        try:
            return self.doc.getObject(self.name) is self.obj and self.obj.Source is not None
        except Exception:  # the document was closed
            return False

    def poll(self):
        if not self.alive():  # deleted, or its document closed: the process ends with it
            self.cancel()
            return
        events = self.proc.poll()
        for ev in events:
            if ev.get("event") == "progress":
                self.obj.Status = "updating: %.0f %% %s" % (100 * (ev.get("fraction") or 0.0),
                                                            ev.get("message") or "")
        if self.proc.finished:
            self.stop()
            self.finish()

    def finish(self):
        """The result into the analysis (or its reason into Status); the report view says so."""
        import FreeCAD
        obj = self.obj
        try:
            a = self.proc.result()
        except (InputError, WorkerFailed) as exc:
            obj.Status = "error: %s" % " ".join(str(exc).splitlines()[0].split()) if str(exc) else "error"
            FreeCAD.Console.PrintError("HullProd: update of %s failed: %s\n" % (obj.Label, obj.Status))
            return
        finally:
            self.proc.close()
        record_planar(a, self.planar)
        obj.Proxy.pending = (a, self.proc.seconds or (time.perf_counter() - self.started))
        obj.touch()
        self.doc.recompute([obj])
        FreeCAD.Console.PrintMessage("HullProd: %s updated in %.1f s: I_D %s (change %+.4g), faces integrated "
                                     "again: %s\n" % (obj.Label, time.perf_counter() - self.started,
                                                      "%.6g" % obj.I_D, obj.DeltaI_D,
                                                      ", ".join(str(f) for f in obj.FacesIntegrated) or "none"))

    def stop(self):
        self.timer.stop()
        RUNNING.pop(self.name, None)

    def cancel(self):
        self.stop()
        self.proc.close()


def start(obj):
    """Reassess obj in the background (a running update of it is cancelled first)."""
    running = RUNNING.pop(obj.Name, None)
    if running is not None:
        running.cancel()
    RUNNING[obj.Name] = Update(obj)


def cancel(obj):
    """Stop obj's running update, if any (its results stay as they were, out of date)."""
    running = RUNNING.pop(obj.Name, None)
    if running is not None:
        running.cancel()
        obj.Status = "out of date: the update was cancelled"


def install():
    """Let recomputes of analyses start background updates (the workbench's GUI set-up)."""
    app_analysis.BACKGROUND = start
