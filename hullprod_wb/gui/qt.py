"""Qt binding: FreeCAD's PySide shim first, then PySide2, then PySide6."""
try:
    from PySide import QtCore, QtGui  # FreeCAD's shim (0.20: PySide2 underneath)
    try:
        from PySide import QtWidgets
    except ImportError:
        QtWidgets = QtGui
except ImportError:  # pragma: no cover - outside FreeCAD
    try:
        from PySide2 import QtCore, QtGui, QtWidgets
    except ImportError:
        from PySide6 import QtCore, QtGui, QtWidgets

__all__ = ["QtCore", "QtGui", "QtWidgets", "close_button", "CloseOnlyPanel"]


def close_button():
    """int of QDialogButtonBox.Close for a task panel's getStandardButtons (PySide2 and 6)."""
    b = QtWidgets.QDialogButtonBox.Close
    return int(getattr(b, "value", b))


class CloseOnlyPanel:
    """Base of read-only task panels: a single Close button that just closes the panel."""

    def getStandardButtons(self):  # noqa: N802 - FreeCAD API
        return close_button()

    def reject(self):
        return True

    def accept(self):
        return True
