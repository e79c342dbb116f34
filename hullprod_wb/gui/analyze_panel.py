"""Analyze task panel: L_ref (automatic proposal or explicit), h_f, k_f and, under
'advanced', the BRep quadrature settings; runs make_analysis for each selected source with
progress and cancellation."""
from ..app import preferences
from ..app.analysis import make_analysis
from ..app.progress import RunProgress
from ..app.reference import proposed_lref
from ..core.errors import InputError
from ..core.progress import Cancelled
from . import dialogs
from .qt import QtCore, QtGui, QtWidgets

#: The last panel opened (scripts and tests drive it).
LAST_PANEL = None


def _float_edit(value, tip):
    e = QtWidgets.QLineEdit("%g" % value)
    v = QtGui.QDoubleValidator(0.0, 1e300, 12, e)
    v.setNotation(QtGui.QDoubleValidator.ScientificNotation)
    e.setValidator(v)
    e.setToolTip(tip)
    return e


def _describe(obj, faces):
    kind = "Part" if hasattr(obj, "Shape") else "Mesh"
    part = ", faces %s" % ", ".join("Face%d" % f for f in faces) if faces else ""
    return "%s (%s%s)" % (obj.Label, kind, part)


class AnalyzePanel:
    """Task panel. sources: [(object, faces or None)]."""

    def __init__(self, sources):
        global LAST_PANEL
        LAST_PANEL = self
        self.sources = list(sources)
        self.created = []
        self.errors = []
        self.running = None
        d = preferences.analysis_defaults()
        self.form = QtWidgets.QWidget()
        self.form.setWindowTitle("HullProd: analyse")
        lay = QtWidgets.QVBoxLayout(self.form)
        src = QtWidgets.QLabel("<b>Assess</b><br>" + "<br>".join(_describe(o, f) for o, f in self.sources))
        src.setWordWrap(True)
        lay.addWidget(src)

        box = QtWidgets.QGroupBox("Reference length L_ref")
        g = QtWidgets.QGridLayout(box)
        self.proposals = []
        for obj, faces in self.sources:
            try:
                self.proposals.append(proposed_lref(obj, faces))
            except InputError as exc:
                self.proposals.append({"value": float("nan"), "method": str(exc), "units": ""})
        p0 = self.proposals[0]
        text = "; ".join("%.6g %s" % (p["value"], p["units"]) for p in self.proposals)
        self.auto_radio = QtWidgets.QRadioButton("automatic: %s" % text)
        self.auto_radio.setToolTip(p0["method"])
        self.explicit_radio = QtWidgets.QRadioButton("explicit (e.g. L_pp):")
        self.lref_edit = _float_edit(p0["value"] if p0["value"] == p0["value"] else 1.0,
                                     "L_ref in the source's length units (FreeCAD Part shapes: mm)")
        self.auto_radio.setChecked(True)
        self.lref_edit.setEnabled(False)
        self.explicit_radio.toggled.connect(self.lref_edit.setEnabled)
        method = QtWidgets.QLabel("<small>method: %s</small>" % p0["method"])
        method.setWordWrap(True)
        self.method_label = method
        g.addWidget(self.auto_radio, 0, 0, 1, 2)
        g.addWidget(method, 1, 0, 1, 2)
        g.addWidget(self.explicit_radio, 2, 0)
        g.addWidget(self.lref_edit, 2, 1)
        lay.addWidget(box)

        box = QtWidgets.QGroupBox("Curvature-class tolerances")
        f = QtWidgets.QFormLayout(box)
        self.hf_edit = _float_edit(d["h_f"], "dimensionless mean-curvature tolerance; tau_H = h_f / L_ref")
        self.kf_edit = _float_edit(d["k_f"], "dimensionless Gaussian-curvature tolerance; tau_K = k_f / L_ref^2")
        f.addRow("h_f", self.hf_edit)
        f.addRow("k_f", self.kf_edit)
        lay.addWidget(box)

        self.advanced = QtWidgets.QGroupBox("Advanced: BRep quadrature")
        self.advanced.setCheckable(True)
        self.advanced.setChecked(False)
        inner = QtWidgets.QWidget()
        f = QtWidgets.QFormLayout(inner)
        self.order_spin = QtWidgets.QSpinBox()
        self.order_spin.setRange(1, 30)
        self.order_spin.setValue(int(d["order"]))
        self.rtol_edit = _float_edit(d["rtol"], "local relative tolerance of the adaptive quadrature")
        self.depth_spin = QtWidgets.QSpinBox()
        self.depth_spin.setRange(0, 20)
        self.depth_spin.setValue(int(d["max_depth"]))
        f.addRow("Gauss-Legendre order", self.order_spin)
        f.addRow("relative tolerance", self.rtol_edit)
        f.addRow("maximum depth", self.depth_spin)
        v = QtWidgets.QVBoxLayout(self.advanced)
        v.addWidget(inner)
        inner.setVisible(False)
        self.advanced.toggled.connect(inner.setVisible)
        if not any(hasattr(o, "Shape") for o, _ in self.sources):
            self.advanced.setEnabled(False)
            self.advanced.setToolTip("meshes are assessed by discrete curvature; no quadrature")
        lay.addWidget(self.advanced)

        self.bar = QtWidgets.QProgressBar()
        self.bar.setRange(0, 1000)
        self.bar.setValue(0)
        self.message = QtWidgets.QLabel("Press OK to run; Cancel (or Esc) stops a running analysis.")
        self.message.setWordWrap(True)
        lay.addWidget(self.bar)
        lay.addWidget(self.message)
        lay.addStretch(1)

    # -- values -------------------------------------------------------------------------------
    def values(self):
        """Keyword arguments of make_analysis from the widgets (InputError on bad text)."""
        def num(edit, name):
            try:
                x = float(edit.text())
            except ValueError:
                raise InputError("%s must be a number, got %r" % (name, edit.text())) from None
            if not x > 0:
                raise InputError("%s must be > 0, got %g" % (name, x))
            return x
        out = {"h_f": num(self.hf_edit, "h_f"), "k_f": num(self.kf_edit, "k_f"),
               "lref": num(self.lref_edit, "L_ref") if self.explicit_radio.isChecked() else None}
        out.update(order=self.order_spin.value(), rtol=num(self.rtol_edit, "relative tolerance"),
                   max_depth=self.depth_spin.value())
        return out

    def _on_progress(self, fraction, message):
        self.bar.setValue(int(1000 * max(0.0, min(1.0, fraction))))
        self.message.setText(message)
        QtWidgets.QApplication.processEvents(QtCore.QEventLoop.AllEvents, 20)

    # -- run --------------------------------------------------------------------------------------
    def run(self):
        """Analyse every source; returns the analyses created. Errors go to dialogs.error."""
        if self.running is not None:
            return []
        try:
            kw = self.values()
        except InputError as exc:
            dialogs.error("invalid setting", str(exc))
            return []
        import FreeCADGui
        made = []
        for obj, faces in self.sources:
            self.running = RunProgress("HullProd: %s" % obj.Label, listener=self._on_progress)
            try:
                a = make_analysis(obj, faces=faces, progress=self.running, **kw)
            except Cancelled:
                self.message.setText("Cancelled: no analysis was created for %s." % obj.Label)
                self.running = None
                break
            except Exception as exc:  # report, never crash the GUI
                self.errors.append(str(exc))
                dialogs.error("analysis of %s failed" % obj.Label, " ".join(str(exc).split()))
                continue
            finally:
                self.running = None
            made.append(a)
            if preferences.get("HideSourceOnAnalyze") and getattr(obj, "ViewObject", None) is not None:
                obj.ViewObject.Visibility = False
        self.created += made
        if made:
            from .commands import legend_to
            legend_to(made[-1:])
            FreeCADGui.Selection.clearSelection()
            FreeCADGui.Selection.addSelection(made[-1])
            view = getattr(FreeCADGui.ActiveDocument, "ActiveView", None)
            if view is not None and hasattr(view, "fitAll"):
                view.fitAll()
        return made

    def accept(self):
        """OK: run; the task view closes the panel when this returns True."""
        made = self.run()
        if len(made) == 1:
            from .validity_panel import show_validity_panel
            QtCore.QTimer.singleShot(0, lambda: show_validity_panel(made[0]))
        return bool(made) or not self.errors

    def reject(self):
        """Cancel: stop a running analysis (panel stays open), otherwise close."""
        if self.running is not None:
            self.running.cancel()
            self.message.setText("Cancelling...")
            return False
        return True


def show_analyze_panel(sources):
    from .qt import show_task_panel
    return show_task_panel(AnalyzePanel(sources))
