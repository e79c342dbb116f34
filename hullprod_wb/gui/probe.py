"""Probe: click a point of an analysed hull to read K, H, k1, k2, q_D and the class there.

A Coin event callback (SoMouseButtonEvent) picks with the view's getObjectInfo; the
values come from hullprod_wb.app.probe (exact BRep evaluation, or barycentric
interpolation for meshes, labelled as such).
"""
from ..app import analysis as app_analysis
from ..app.probe import probe_analysis
from . import dialogs, wording
from .qt import QtWidgets, close_button

#: The active probe panel (scripts and tests drive it).
ACTIVE = None

COLUMNS = ("#", "object", "K", "H", "k1", "k2", "q_D", "class", "how")


def length_unit(analyses):
    """The length unit the curvatures are per ('mm' for Part shapes, 'unit' otherwise)."""
    units = {str(a.Units) for a in analyses}
    return "mm" if any("mm" in u for u in units) else "unit"


def headers(analyses):
    """Column titles with units: K per length squared, H, k1, k2 per length, q_D dimensionless."""
    u = length_unit(analyses)
    per = {"K": "1/%s\u00b2" % u, "H": "1/%s" % u, "k1": "1/%s" % u, "k2": "1/%s" % u, "q_D": "-"}
    return ["%s (%s)" % (c, per[c]) if c in per else c for c in COLUMNS]


class NothingSelectable:
    """Selection gate of the probe mode: no object or sub-element can be selected."""

    def allow(self, doc, obj, sub):
        return False


class ProbePanel:
    """Task panel listing probed points; closing it ends the probe mode."""

    def __init__(self, view, analyses):
        global ACTIVE
        ACTIVE = self
        from pivy import coin
        self.view = view
        self.analyses = {a.Name: a for a in analyses}
        self.results = []
        self.form = QtWidgets.QWidget()
        self.form.setWindowTitle("HullProd probe")
        lay = QtWidgets.QVBoxLayout(self.form)
        self.hint = QtWidgets.QLabel("Click on the coloured hull. BRep values are exact at the surface point "
                                     "under the cursor; mesh values are interpolated in the picked triangle.")
        self.hint.setWordWrap(True)
        lay.addWidget(self.hint)
        self.table = QtWidgets.QTableWidget(0, len(COLUMNS))
        self.table.setHorizontalHeaderLabels(headers(analyses))
        self.table.verticalHeader().setVisible(False)
        lay.addWidget(self.table)
        self.last = QtWidgets.QLabel("")
        self.last.setWordWrap(True)
        lay.addWidget(self.last)
        self._type = coin.SoMouseButtonEvent.getClassTypeId()
        self._cb = view.addEventCallbackPivy(self._type, self.on_mouse)
        # A probe click reads the surface; selecting the hull would paint it in the
        # selection colour over its map, so nothing is selectable while the probe runs.
        import FreeCADGui
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelectionGate(NothingSelectable())
        self._gate = True
        # However the panel goes (Close, another task, document closed), the mode ends.
        self.form.destroyed.connect(lambda *args: self.stop())

    def on_mouse(self, event_callback):
        from pivy import coin
        ev = event_callback.getEvent()
        if ev.getButton() == coin.SoMouseButtonEvent.BUTTON1 and ev.getState() == coin.SoButtonEvent.DOWN:
            x, y = ev.getPosition().getValue()
            if self.pick_at((int(x), int(y))) is not None:
                event_callback.setHandled()

    def _analysis_for(self, name):
        import FreeCAD
        obj = FreeCAD.ActiveDocument.getObject(name) if FreeCAD.ActiveDocument else None
        if obj is None:
            return None
        if app_analysis.is_analysis(obj):
            return obj
        for a in self.analyses.values():  # clicked the (visible) source of an analysis
            if a.Source is not None and a.Source.Name == obj.Name:
                return a
        return None

    def pick_at(self, pos):
        """Probe the analysis under screen position pos (pixels); returns the result or None."""
        info = self.view.getObjectInfo(tuple(pos))
        if not info:
            return None
        obj = self._analysis_for(info.get("Object"))
        if obj is None:
            self.last.setText("%s is not an analysed hull" % info.get("Object"))
            return None
        return self.probe(obj, (info["x"], info["y"], info["z"]))

    def probe(self, obj, point):
        """Probe analysis obj at a model point; adds a table row and a marker."""
        try:
            r = probe_analysis(obj, point)
        except Exception as exc:  # report, never crash the GUI
            dialogs.error("probe", " ".join(str(exc).split()))
            return None
        r["object"] = obj.Label
        self.results.append(r)
        row = self.table.rowCount()
        self.table.insertRow(row)
        how = "exact" if r["exact"] else "interpolated"
        cells = [str(row + 1), obj.Label] + [wording.format_value(r[k], 5) for k in ("K", "H", "k1", "k2", "q_D")]
        cells += [r["class_name"], how]
        for j, text in enumerate(cells):
            self.table.setItem(row, j, QtWidgets.QTableWidgetItem(text))
        self.table.item(row, len(cells) - 1).setToolTip(r["method"])
        self.table.resizeColumnsToContents()
        self.last.setText("point (%.6g, %.6g, %.6g): %s, %s" % (tuple(r["point"]) + (r["class_name"], r["method"])))
        import FreeCAD
        FreeCAD.Console.PrintMessage("HullProd probe %s at (%.6g, %.6g, %.6g): K=%.6g H=%.6g k1=%.6g k2=%.6g "
                                     "q_D=%.6g class=%s [%s]\n" % ((obj.Label,) + tuple(r["point"]) + tuple(
                                         r[k] for k in ("K", "H", "k1", "k2", "q_D")) + (r["class_name"], r["method"])))
        vp = getattr(obj.ViewObject, "Proxy", None)
        if vp is not None and hasattr(vp, "show_marker"):
            bb = obj.Source.Shape.BoundBox if hasattr(obj.Source, "Shape") else obj.Source.Mesh.BoundBox
            vp.show_marker(r["point"], 0.006 * bb.DiagonalLength)
        return r

    def stop(self):
        """End the probe mode: the mouse callback and the markers go."""
        global ACTIVE
        for a in self.analyses.values():
            try:
                vp = getattr(a.ViewObject, "Proxy", None)
            except Exception:  # the object was deleted meanwhile
                continue
            if vp is not None and hasattr(vp, "clear_marker"):
                vp.clear_marker()
        if self._cb is not None:
            try:
                self.view.removeEventCallbackPivy(self._type, self._cb)
            except Exception:  # the view was closed
                pass
            self._cb = None
        if getattr(self, "_gate", False):
            import FreeCADGui
            FreeCADGui.Selection.removeSelectionGate()
            self._gate = False
        if ACTIVE is self:
            ACTIVE = None

    def getStandardButtons(self):  # noqa: N802 - FreeCAD API
        return close_button()

    def reject(self):
        self.stop()
        return True

    def accept(self):
        return self.reject()


def start_probe(analyses):
    """Open the probe panel for the analyses in the active 3D view."""
    import FreeCADGui
    view = FreeCADGui.ActiveDocument.ActiveView
    if not hasattr(view, "addEventCallbackPivy"):
        raise RuntimeError("the active view is not a 3D view")
    if ACTIVE is not None:
        ACTIVE.stop()
    if FreeCADGui.Control.activeDialog():  # before the panel starts listening to the view
        FreeCADGui.Control.closeDialog()
    from .on_screen import show_task_panel
    return show_task_panel(ProbePanel(view, analyses))
