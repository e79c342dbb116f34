"""The 'Verification' menu: the paper's verification studies (section 5) on the source of
a selected analysis, run like Analyze in an assessment process (app.study_run), with a
progress dialog and Cancel, the GUI responsive; the HTML report is written where the user
chooses (default: beside the document) and opened in the browser.

HullProd_StudySameFace, HullProd_StudyRefinement, HullProd_StudyRepresentation,
HullProd_StudyThresholds. The numerics are hullprod_wb.studies; this module only presents.
"""
import time
import webbrowser

import FreeCAD
import FreeCADGui

from ..app.assessment_process import AssessmentProcess, WorkerFailed
from ..app.study_run import BREP_ONLY, default_report_path, study_settings
from ..core.errors import InputError
from . import dialogs
from .commands import _Command, selected_analyses
from .qt import QtCore, QtWidgets

#: Milliseconds between two polls of the study's process.
POLL_MS = 50
#: The study of the last command (macros and tests wait on it).
LAST_RUN = None


class StudyRun:
    """One study of one analysis in its own process; a Qt timer reads its events, so the
    event loop never waits on it. Cancel (dialog button or cancel()) ends the process."""

    def __init__(self, kind, analysis, report_path):
        self.kind, self.analysis, self.report_path = kind, analysis, report_path
        src, faces, options = study_settings(analysis)
        self.label = src.Label
        self.report = self.error = None
        self.events = 0
        self.proc = AssessmentProcess(src, faces, propose=False)
        self.proc.run_study(kind, options)
        self.started = time.perf_counter()
        self.dialog = QtWidgets.QProgressDialog("%s study of %s: starting" % (kind, self.label), "Cancel", 0, 1000,
                                                FreeCADGui.getMainWindow())
        self.dialog.setWindowTitle("HullProd %s study" % kind)
        self.dialog.setWindowModality(QtCore.Qt.NonModal)
        self.dialog.setMinimumDuration(0)
        self.dialog.setAutoClose(False)
        self.dialog.setAutoReset(False)
        self.dialog.canceled.connect(self.cancel)
        self.dialog.show()
        self.timer = QtCore.QTimer()
        self.timer.setInterval(POLL_MS)
        self.timer.timeout.connect(self.poll)
        self.timer.start()

    @property
    def finished(self):
        return not self.timer.isActive()

    def poll(self):
        """Timer: show the latest progress; on the end, write and open the report."""
        events = [ev for ev in self.proc.poll() if ev.get("event") == "progress"]
        self.events += len(events)
        if events:
            ev = events[-1]
            self.dialog.setValue(int(1000 * max(0.0, min(1.0, ev["fraction"]))))
            self.dialog.setLabelText("%s study of %s: %s" % (self.kind, self.label, ev["message"]))
        if self.proc.finished:
            self._finish()

    def cancel(self):
        """End the study's process now; no report is written."""
        if not self.finished:
            self.proc.cancel()
            self._finish()

    def _finish(self):
        self.timer.stop()
        self.seconds = time.perf_counter() - self.started
        self.dialog.close()
        try:
            if self.proc.state == "cancelled":
                dialogs.info("%s study" % self.kind, "Cancelled: no report was written for %s." % self.label)
                return
            self._report(self.proc.study_result())
        except (InputError, WorkerFailed) as exc:
            self.error = str(exc).splitlines()[0]
            dialogs.error("%s study of %s" % (self.kind, self.label), self.error)
        except OSError as exc:
            self.error = "cannot write the report: %s" % exc
            dialogs.error("%s study of %s" % (self.kind, self.label), self.error)
        finally:
            self.proc.close()

    def _report(self, study):
        from ..studies import write_report
        self.study = study
        title = "HullProd %s study: %s" % (self.kind, self.label)
        self.report = write_report(None, self.report_path, studies=study, title=title)
        headline = ""
        if self.kind == "sameface":
            from ..studies.cli import sameface_summary
            headline = "\n".join(sameface_summary(study)[:2]) + "\n"
        FreeCAD.Console.PrintMessage("HullProd %s study of %s: %s\n%s" % (self.kind, self.label, self.report,
                                                                          headline))
        if dialogs.INTERACTIVE:
            webbrowser.open("file://" + self.report)
        dialogs.info("%s study" % self.kind, "%sReport written to\n%s" % (headline, self.report))


class _Study(_Command):
    kind = ""

    def IsActive(self):  # noqa: N802 - FreeCAD API
        return FreeCAD.ActiveDocument is not None

    def run(self):
        global LAST_RUN
        analysis = selected_analyses()[0]
        src = analysis.Source
        if src is None:
            raise InputError("the analysis %s has no source object" % analysis.Label)
        if not hasattr(src, "Shape") and self.kind in BREP_ONLY:
            raise InputError("this study needs a BRep (Part) source; %s is a mesh" % src.Label)
        default = default_report_path(getattr(analysis.Document, "FileName", ""), src.Label, self.kind)
        path = dialogs.ask_save_file("Save the %s study report of %s" % (self.kind, src.Label), default)
        if path:
            LAST_RUN = StudyRun(self.kind, analysis, path)


class StudySameFace(_Study):
    name = "HullProd_StudySameFace"
    menu = "Same-face curvature &recovery"
    tip = ("BRep-to-mesh curvature recovery on 12x12, 24x24, 48x48 grids of each face (eps_H, eps_K); "
           "headline: the face of largest area, with the largest-|K| face beside it")
    kind = "sameface"


class StudyRefinement(_Study):
    name = "HullProd_StudyRefinement"
    menu = "Mesh-&resolution sensitivity"
    tip = "Signature on three tessellations of the BRep, changes and class distance d1 against the finest"
    kind = "refinement"


class StudyRepresentation(_Study):
    name = "HullProd_StudyRepresentation"
    menu = "Re&presentation: BRep against mesh"
    tip = "Native BRep signature next to a fine triangulated realization of the same hull"
    kind = "representation"


class StudyThresholds(_Study):
    name = "HullProd_StudyThresholds"
    menu = "&Threshold study"
    tip = ("Class fractions for h_f = k_f = 1e-5, 1e-4, 1e-3 and the analysis's own tolerance; "
           "I_D is threshold independent")
    kind = "thresholds"


COMMANDS = [StudySameFace, StudyRefinement, StudyRepresentation, StudyThresholds]
MENU = [c.name for c in COMMANDS]
_REGISTERED = False


def register():
    global _REGISTERED
    if not _REGISTERED:
        for cls in COMMANDS:
            FreeCADGui.addCommand(cls.name, cls())
        _REGISTERED = True
    return MENU
