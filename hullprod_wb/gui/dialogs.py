"""Messages and file dialogs in one place: the report view always, a dialog when
interactive. Scripts that drive the GUI (tests, batch macros) set INTERACTIVE = False and
pre-load ANSWERS; every message is also kept in LOG."""
import FreeCAD

from .qt import QtWidgets

#: False: never open a modal dialog (messages only go to the report view and LOG).
INTERACTIVE = True
#: Queued answers for ask_directory when not interactive.
ANSWERS = []
#: (kind, title, text) of every message shown.
LOG = []


def _parent():
    try:
        import FreeCADGui
        return FreeCADGui.getMainWindow()
    except Exception:  # pragma: no cover - no main window
        return None


def error(title, text):
    """Report an error: report view (PrintError) and a message box."""
    LOG.append(("error", title, text))
    FreeCAD.Console.PrintError("HullProd: %s: %s\n" % (title, text))
    if INTERACTIVE:
        QtWidgets.QMessageBox.critical(_parent(), "HullProd: " + title, text)


def warning(title, text):
    LOG.append(("warning", title, text))
    FreeCAD.Console.PrintWarning("HullProd: %s: %s\n" % (title, text))
    if INTERACTIVE:
        QtWidgets.QMessageBox.warning(_parent(), "HullProd: " + title, text)


def info(title, text):
    LOG.append(("info", title, text))
    FreeCAD.Console.PrintMessage("HullProd: %s: %s\n" % (title, text))
    if INTERACTIVE:
        QtWidgets.QMessageBox.information(_parent(), "HullProd: " + title, text)


def ask_directory(title, start=""):
    """A folder chosen by the user (or the next queued answer), None when cancelled."""
    if not INTERACTIVE:
        return ANSWERS.pop(0) if ANSWERS else None
    path = QtWidgets.QFileDialog.getExistingDirectory(_parent(), title, start)
    return path or None


def ask_save_file(title, default, pattern="HTML (*.html)"):
    """A file name to write chosen by the user, starting at default (the next queued
    answer, else default, when not interactive); None when cancelled."""
    if not INTERACTIVE:
        return ANSWERS.pop(0) if ANSWERS else default
    path, _ = QtWidgets.QFileDialog.getSaveFileName(_parent(), title, default, pattern)
    return path or None


def ask_yes_no(title, text, default=False):
    if not INTERACTIVE:
        return ANSWERS.pop(0) if ANSWERS else default
    b = QtWidgets.QMessageBox.question(_parent(), "HullProd: " + title, text,
                                       QtWidgets.QMessageBox.Yes | QtWidgets.QMessageBox.No)
    return b == QtWidgets.QMessageBox.Yes
