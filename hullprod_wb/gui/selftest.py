"""GUI self-test of an installed workbench, in a running FreeCAD GUI: each check a plain
function that raises AssertionError saying what differs, and returns what it saw.

FreeCAD's Test workbench runs them through TestHullProdGui (registered in InitGui.py);
tests/gui_scripts/gui_checks.py calls the same functions in its GUI session.
"""
import time

from ..selftest import check, source_fingerprint as fingerprint, wigley_feature
from .on_screen import describe, seen_by_a_person
from .qt import QtCore, QtWidgets

WORKBENCH = "HullProdWorkbench"
#: Seconds the event loop is given to lay out and paint a panel just opened.
SETTLE = 0.3


def process(seconds=SETTLE):
    """Run the event loop for seconds."""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        QtWidgets.QApplication.processEvents(QtCore.QEventLoop.AllEvents, 20)


def check_seen(widget, what):
    """The on-screen record of widget; AssertionError unless a person sees it (another
    top-level window over it, such as the Test workbench's runner, is let pass)."""
    rec = seen_by_a_person(widget, other_windows_ok=True)
    check(rec["seen"], "%s is not seen on screen: %s (%s)" % (what, rec.get("why"), rec))
    return rec


def task_button(form, which):
    """The task dialog's standard button (QDialogButtonBox.Ok, .Cancel, ...) that belongs to
    the task panel holding form, or None: searched in the form's ancestors, nearest first."""
    w = form.parentWidget()
    while w is not None and not isinstance(w, QtWidgets.QMainWindow):
        for box in w.findChildren(QtWidgets.QDialogButtonBox):
            button = box.button(which)
            if button is not None:
                return button
        w = w.parentWidget()
    return None


def running_seen(panel):
    """On-screen records of an Analyze panel's progress bar and of its task dialog's Cancel
    button (to look at while a run goes on): {'bar': record, 'cancel': record}."""
    cancel = task_button(panel.form, QtWidgets.QDialogButtonBox.Cancel)
    return {"bar": seen_by_a_person(panel.bar),
            "cancel": seen_by_a_person(cancel) if cancel is not None else {"seen": False, "why": "no Cancel button"}}


def hull_document(name="HullProdSelfTest"):
    """A new document holding the half-Wigley hull (hullprod_wb.examples.builtin) as a
    Part::Feature; returns (doc, feature)."""
    import FreeCAD
    doc = FreeCAD.newDocument(name)
    return doc, wigley_feature(doc)


def close_document(doc):
    """Close a task dialog left open and the document (if still open)."""
    import FreeCAD
    import FreeCADGui
    if FreeCADGui.Control.activeDialog():
        FreeCADGui.Control.closeDialog()
    if doc is not None and doc.Name in FreeCAD.listDocuments():
        FreeCAD.closeDocument(doc.Name)
    process(0.05)


class commands_registered:
    """with commands_registered(): the workbench's commands exist (FreeCAD registers them when
    the workbench is first activated); the workbench active before is active again after."""

    def __enter__(self):
        import FreeCADGui
        self.before = FreeCADGui.activeWorkbench().name()
        FreeCADGui.activateWorkbench(WORKBENCH)
        self.active = FreeCADGui.activeWorkbench().name()
        return self

    def __exit__(self, *exc):
        import FreeCADGui
        if self.before != WORKBENCH:
            FreeCADGui.activateWorkbench(self.before)


def check_workbench():
    """The workbench activates; its commands and its Verification menu's are registered."""
    import FreeCADGui
    from . import commands, verification_commands
    with commands_registered() as wb:
        active = wb.active
    check(active == WORKBENCH, "active workbench is %s, not %s" % (active, WORKBENCH))
    listed = set(FreeCADGui.listCommands())
    names = [c.name for c in commands.COMMANDS] + list(verification_commands.MENU)
    missing = [n for n in names if n not in listed]
    check(not missing, "commands not registered: %s" % missing)
    return {"active": active, "commands": names}


def check_analysis_view():
    """make_analysis on the half-Wigley (L_ref = 1) in a new document: the analysis gets
    its view provider, is drawn with more than one colour, and the source is unchanged."""
    import hullprod_wb
    from .colormaps import distinct_colors
    from .view_provider import ViewProviderHullProdAnalysis
    doc, src = hull_document()
    try:
        before = fingerprint(src)
        a = hullprod_wb.make_analysis(src, lref=1.0)
        process(0.1)
        check(a.Status == "ok", "analysis status %r" % a.Status)
        vp = getattr(a.ViewObject, "Proxy", None)
        check(isinstance(vp, ViewProviderHullProdAnalysis), "view provider is %r" % (vp,))
        distinct = distinct_colors(vp.coin_colors())
        check(distinct > 1, "the analysis is drawn with %d colour(s)" % distinct)
        check(fingerprint(src) == before, "the source changed: %s -> %s" % (before, fingerprint(src)))
        return {"distinct_colors": int(distinct), "I_D": a.I_D}
    finally:
        close_document(doc)


def _closes(form, what):
    """Close the task dialog; AssertionError unless it is gone and form no longer shown."""
    import FreeCADGui
    FreeCADGui.Control.closeDialog()
    process(0.1)
    check(not FreeCADGui.Control.activeDialog(), "%s: a task dialog is still open after closeDialog" % what)
    try:
        shown = form.isVisible()
    except RuntimeError:  # the C++ widget is deleted with the dialog
        shown = False
    check(not shown, "%s is still shown after closeDialog" % what)


def check_analyze_panel():
    """HullProd_Analyze on the selected half-Wigley opens the Analyze panel, which a person
    sees (on_screen.seen_by_a_person), and which closes."""
    import FreeCADGui
    from . import analyze_panel
    doc, src = hull_document()
    try:
        before = analyze_panel.LAST_PANEL
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(src)
        with commands_registered():
            FreeCADGui.runCommand("HullProd_Analyze")
            process()
        p = analyze_panel.LAST_PANEL
        check(p is not None and p is not before, "HullProd_Analyze opened no panel")
        rec = check_seen(p.form, "the Analyze panel")
        _closes(p.form, "the Analyze panel")
        return rec
    finally:
        close_document(doc)


def opened_validity_panel(obj):
    """Run HullProd_ValidityPanel with obj selected; returns the panel it opened (None if none)."""
    import FreeCADGui
    from . import validity_panel
    orig, got = validity_panel.show_validity_panel, []

    def capture(o):
        got.append(orig(o))
        return got[-1]
    validity_panel.show_validity_panel = capture
    try:
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(obj)
        with commands_registered():
            FreeCADGui.runCommand("HullProd_ValidityPanel")
    finally:
        validity_panel.show_validity_panel = orig
    return got[-1] if got else None


def check_validity_panel():
    """HullProd_ValidityPanel on an analysis of the half-Wigley opens the validity panel,
    which a person sees, and which closes."""
    import hullprod_wb
    doc, src = hull_document()
    try:
        a = hullprod_wb.make_analysis(src, lref=1.0)
        p = opened_validity_panel(a)
        check(p is not None, "HullProd_ValidityPanel opened no panel")
        process()
        rec = check_seen(p.form, "the validity panel")
        _closes(p.form, "the validity panel")
        return rec
    finally:
        close_document(doc)


def run_suite(module_name="TestHullProdGui"):
    """Run a unittest module in this session; {'run', 'failures', 'errors', 'skipped',
    'problems'} (problems: the failing tests' names and last traceback lines)."""
    import importlib
    import io
    import unittest
    module = importlib.import_module(module_name)
    suite = unittest.defaultTestLoader.loadTestsFromModule(module)
    result = unittest.TextTestRunner(stream=io.StringIO(), verbosity=2).run(suite)
    problems = [[str(t), tb.strip().splitlines()[-1]] for t, tb in result.failures + result.errors]
    return {"run": result.testsRun, "failures": len(result.failures), "errors": len(result.errors),
            "skipped": len(result.skipped), "problems": problems, "file": getattr(module, "__file__", None)}


__all__ = ["check", "check_seen", "check_workbench", "check_analysis_view", "check_analyze_panel",
           "check_validity_panel", "task_button", "running_seen", "run_suite", "describe"]
