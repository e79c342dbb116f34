"""Preferences page 'HullProd' (Edit > Preferences): default h_f, k_f, quadrature
settings, default colour map; stored in hullprod_wb.app.preferences.PARAM_PATH."""
from ..app import preferences
from . import colormaps
from .qt import QtGui, QtWidgets


class PreferencesPage:
    """FreeCAD preference page (loadSettings / saveSettings on the parameter group)."""

    def __init__(self, parent=None):
        self.form = QtWidgets.QWidget(parent)
        self.form.setWindowTitle("HullProd")
        f = QtWidgets.QFormLayout(self.form)
        self.edits = {}
        for name, label in (("DefaultHf", "default h_f (mean-curvature tolerance)"),
                            ("DefaultKf", "default k_f (Gaussian-curvature tolerance)"),
                            ("QuadratureRtol", "BRep quadrature relative tolerance")):
            e = QtWidgets.QLineEdit()
            val = QtGui.QDoubleValidator(0.0, 1.0, 12, e)
            val.setNotation(QtGui.QDoubleValidator.ScientificNotation)
            e.setValidator(val)
            f.addRow(label, e)
            self.edits[name] = e
        self.order = QtWidgets.QSpinBox()
        self.order.setRange(1, 30)
        self.depth = QtWidgets.QSpinBox()
        self.depth.setRange(0, 20)
        f.addRow("BRep Gauss-Legendre order", self.order)
        f.addRow("BRep maximum refinement depth", self.depth)
        self.colormap = QtWidgets.QComboBox()
        self.colormap.addItems(list(colormaps.MAPS))
        f.addRow("colour map of a new analysis", self.colormap)
        self.hide_source = QtWidgets.QCheckBox("hide the source object when its analysis is shown")
        f.addRow(self.hide_source)
        self.loadSettings()

    def loadSettings(self):  # noqa: N802 - FreeCAD API
        for name, e in self.edits.items():
            e.setText("%g" % preferences.get(name))
        self.order.setValue(int(preferences.get("QuadratureOrder")))
        self.depth.setValue(int(preferences.get("QuadratureMaxDepth")))
        i = self.colormap.findText(preferences.get("DefaultColorMap"))
        self.colormap.setCurrentIndex(max(i, 0))
        self.hide_source.setChecked(bool(preferences.get("HideSourceOnAnalyze")))

    def saveSettings(self):  # noqa: N802 - FreeCAD API
        for name, e in self.edits.items():
            try:
                x = float(e.text())
            except ValueError:
                continue  # keep the stored value rather than store garbage
            if x > 0:
                preferences.set(name, x)
        preferences.set("QuadratureOrder", self.order.value())
        preferences.set("QuadratureMaxDepth", self.depth.value())
        preferences.set("DefaultColorMap", self.colormap.currentText())
        preferences.set("HideSourceOnAnalyze", self.hide_source.isChecked())
