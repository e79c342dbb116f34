"""Validity and provenance panel of one analysis (a task panel).

Seven signature rows with value and coloured status, each with its reason on a row beneath;
areas; evidence; where the numbers come from (backend, file, sha256, units, L_ref, faces,
software); the per-face (plate) table for a BRep; colour-map buttons with the legend; the
JSON one click away.
"""
import json

from ..app import analysis as app_analysis
from ..core.constants import METRIC_LABELS, METRICS
from . import colormaps, wording
from .wording import area_text
from .legend import make_legend_widget
from .qt import QtCore, QtGui, QtWidgets, CloseOnlyPanel

#: Narrowest signature table in average characters: a reason wraps a phrase per line.
REASON_CHARS = 28

FACE_COLUMNS = ("face", "status", "I_D", "share", "area", "surface", "I_D+", "I_D-", "flat", "single",
                "elliptic", "saddle")


def units_text(units, fallback=""):
    """The provenance's units record as a sentence ('working: mm; source: inch')."""
    if isinstance(units, dict):
        parts = []
        if units.get("working_unit"):
            parts.append("lengths in %s" % units["working_unit"])
        if units.get("source_unit") and units.get("source_unit") != units.get("working_unit"):
            parts.append("source declared %s" % units["source_unit"])
        if units.get("note"):
            parts.append(units["note"])
        return "; ".join(parts) or fallback
    return str(units or fallback)


def _item(text, tip=None):
    it = QtWidgets.QTableWidgetItem(str(text))
    it.setFlags(it.flags() & ~QtCore.Qt.ItemIsEditable)
    if tip:
        it.setToolTip(tip)
    return it


def _fill_tree(parent, value):
    """Expandable tree of a JSON value under parent (a QTreeWidget or item)."""
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list) else ()
    for key, val in items:
        node = QtWidgets.QTreeWidgetItem([str(key), "" if isinstance(val, (dict, list)) else json.dumps(val)])
        if isinstance(parent, QtWidgets.QTreeWidget):
            parent.addTopLevelItem(node)
        else:
            parent.addChild(node)
        if isinstance(val, (dict, list)):
            node.setText(1, "{%d}" % len(val) if isinstance(val, dict) else "[%d]" % len(val))
            _fill_tree(node, val)



def change_line(obj):
    """The change of the last run against the one before: delta I_D and the faces
    integrated again (the others came from the faces' store); "" before a second run."""
    delta = getattr(obj, "DeltaI_D", float("nan"))
    if delta != delta:  # NaN: no result before, or I_D not established in one of them
        return ""
    faces = list(getattr(obj, "FacesIntegrated", []) or [])
    used = list(getattr(obj, "FacesUsed", []) or [])
    again = ("every face integrated" if used and len(faces) >= len(used) else
             "integrated again: %s; the other %d from the faces' store"
             % (", ".join("Face%d" % f for f in faces[:8]) + (" ..." if len(faces) > 8 else "") or "none",
                max(len(used) - len(faces), 0)))
    return "Change against the previous result: I_D %+.4g (%s)" % (delta, again)

class ValidityPanel(CloseOnlyPanel):
    """Task panel: signature table, provenance, per-face table, colour maps, JSON."""

    def __init__(self, obj):
        self.obj = obj
        self.doc = app_analysis.result_document(obj)
        self.form = QtWidgets.QWidget()
        self.form.setWindowTitle("HullProd validity")
        lay = QtWidgets.QVBoxLayout(self.form)
        lay.setContentsMargins(0, 0, 0, 0)  # the task box has its own: the panel fits a narrow combo view
        lay.addWidget(self._header())
        lay.addWidget(self._signature_table())
        lay.addWidget(self._areas())
        lay.addWidget(self._maps())
        if self.doc.get("provenance", {}).get("faces"):
            lay.addWidget(self._face_table())
        lay.addWidget(self._provenance())
        lay.addLayout(self._buttons())
        self.tree = QtWidgets.QTreeWidget()
        self.tree.setHeaderLabels(["key", "value"])
        _fill_tree(self.tree, self.doc)
        self.tree.setVisible(False)
        self.tree.setMinimumHeight(220)
        lay.addWidget(self.tree)

    # -- sections -------------------------------------------------------------------------------
    def _header(self):
        o, rl, th = self.obj, self.doc["reference_length"], self.doc["thresholds"]
        src = o.Source.Label if o.Source else "?"
        text = ("<b>%s</b> &mdash; %s of <i>%s</i><br>L_ref = %.6g %s (%s)%s<br>h_f = %g, k_f = %g "
                "(tau_H = %.3g, tau_K = %.3g)" % (
                    o.Label, "native BRep" if o.Representation == "brep" else "triangle mesh", src,
                    rl["value"], app_analysis.length_unit_label(o), rl["mode"],
                    "" if rl["mode"] == "automatic" else "; automatic proposal %.6g" % rl["automatic_value"],
                    th["h_f"], th["k_f"], th["tau_H"], th["tau_K"]))
        if o.Status != "ok":
            text += "<br><span style='color:#c0392b'>%s</span>" % o.Status
        change = change_line(o)
        if change:
            text += "<br>" + change
        if rl.get("plausibility_warning"):
            text += "<br><span style='color:#d4a017'>%s</span>" % rl["plausibility_warning"]
        lab = QtWidgets.QLabel(text)
        lab.setWordWrap(True)
        return lab

    def _fit_rows(self):
        """Rows as tall as their wrapped reason at the table's present width."""
        t = self.signature_table
        t.resizeRowsToContents()
        span = sum(t.columnWidth(j) for j in range(3))
        for i in range(1, t.rowCount(), 2):  # a reason wraps across its row's span, not one column
            t.setRowHeight(i, t.cellWidget(i, 0).heightForWidth(span) + 2)
        t.setMinimumHeight(t.horizontalHeader().height() + sum(t.rowHeight(i) for i in range(t.rowCount())) + 6)

    def signature_cells(self):
        """[metric, value, status, meaning / reason] of each metric, as the table shows them."""
        t = self.signature_table
        return [[t.item(2 * i, j).text() for j in range(3)] + [t.cellWidget(2 * i + 1, 0).text()]
                for i in range(len(METRICS))]

    def _signature_table(self):
        """Metric, value and status side by side; beneath each, its meaning and reason on a
        row spanning the table, wrapped to the panel's width (a narrow task view keeps a
        phrase per line instead of one word)."""
        t = QtWidgets.QTableWidget(2 * len(METRICS), 3)
        t.setHorizontalHeaderLabels(["metric", "value", "status"])
        t.verticalHeader().setVisible(False)
        self.rows, first_said = [], {}
        for i, m in enumerate(METRICS):
            rec = self.doc["validity"][m]
            status = rec["status"]
            t.setItem(2 * i, 0, _item(METRIC_LABELS[m], wording.METRIC_TEXT[m]))
            t.setItem(2 * i, 1, _item(wording.format_value(rec["value"])))
            st = _item(status, wording.status_sentence(status) + "\n\nevidence:\n" +
                       json.dumps(rec.get("evidence", {}), indent=1)[:2000])
            st.setBackground(QtGui.QBrush(QtGui.QColor(wording.status_color(status))))
            st.setForeground(QtGui.QBrush(QtGui.QColor("white")))
            t.setItem(2 * i, 2, st)
            reason = rec.get("reason") or ""
            full = wording.status_sentence(status) + (" \u2014 " + reason if reason else "")
            if first_said.get(full):  # the same sentence again: named once, pointed to after
                why = QtWidgets.QLabel("%s: as for %s." % (status, first_said[full]))
                why.setToolTip(full)
            else:
                first_said[full] = METRIC_LABELS[m]
                why = QtWidgets.QLabel(full)
                why.setToolTip(reason)
            why.setWordWrap(True)
            why.setTextFormat(QtCore.Qt.PlainText)
            why.setContentsMargins(4, 1, 4, 1)
            t.setSpan(2 * i + 1, 0, 1, 3)
            t.setCellWidget(2 * i + 1, 0, why)
            self.rows.append({"metric": m, "value": rec["value"], "status": status, "reason": reason,
                              "color": wording.status_color(status)})
        t.setWordWrap(True)
        header = t.horizontalHeader()
        fm = t.fontMetrics()
        for j in (0, 1):  # metric and value whole; the status (named again beneath) takes the rest
            texts = [t.horizontalHeaderItem(j).text()] + [t.item(2 * i, j).text() for i in range(len(METRICS))]
            header.setSectionResizeMode(j, QtWidgets.QHeaderView.Fixed)
            t.setColumnWidth(j, max(fm.horizontalAdvance(x) for x in texts) + 2 * fm.averageCharWidth())
        header.setSectionResizeMode(2, QtWidgets.QHeaderView.Stretch)
        t.setHorizontalScrollBarPolicy(QtCore.Qt.ScrollBarAlwaysOff)
        t.setMinimumWidth(REASON_CHARS * fm.averageCharWidth() + 2 * t.frameWidth())
        self.signature_table = t
        header.sectionResized.connect(lambda *args: self._fit_rows())
        self._fit_rows()
        return t

    def _areas(self):
        ig = self.doc.get("integrals", {})
        rep, valid = ig.get("represented_area") or 0.0, ig.get("valid_area") or 0.0
        share = 100.0 * valid / rep if rep else float("nan")
        units = app_analysis.length_unit_label(self.obj)
        ev_text = wording.evidence_text(self.doc["validity"]["I_D"].get("evidence", {}), units, rep)
        lab = QtWidgets.QLabel("Represented area %s, valid area %s (%.2f %%).<br>"
                               "Evidence (I_D): %s" % (area_text(rep, units), area_text(valid, units, rep), share,
                                                       ev_text or "none recorded"))
        lab.setWordWrap(True)
        self.areas_label = lab
        return lab

    def _maps(self):
        box = QtWidgets.QGroupBox("Colour map on the hull")
        v = QtWidgets.QVBoxLayout(box)
        h = QtWidgets.QGridLayout()  # two by two: fits a narrow combo view
        self.map_buttons = {}
        for k, mode in enumerate(colormaps.MAPS):
            b = QtWidgets.QPushButton(mode)
            b.setCheckable(True)
            b.clicked.connect(lambda checked=False, m=mode: self.set_map(m))
            h.addWidget(b, k // 2, k % 2)
            self.map_buttons[mode] = b
        v.addLayout(h)
        if self.obj.Representation != "brep":
            self.map_buttons["Plates"].setEnabled(False)
            self.map_buttons["Plates"].setToolTip("the plate view colours BRep faces; this is a triangle mesh")
            self.map_buttons["Change"].setEnabled(False)
            self.map_buttons["Change"].setToolTip("the change view colours BRep faces; this is a triangle mesh")
        else:
            self.map_buttons["Change"].setToolTip("each face by the change of its share of I_D against the "
                                                  "result before (after an edit of the source)")
        v.addLayout(self._scale_row())
        vp = self._vp()
        self.legend_widget = make_legend_widget(vp.legend if vp is not None and vp.legend else
                                                colormaps.Legend("no colours yet", "categorical"))
        v.addWidget(self.legend_widget)
        self._sync_map_buttons()
        return box

    def _scale_row(self):
        """Scale of the developability and signed maps: a range (percentiles, from k_f, or a
        fixed preset) and linear or logarithmic; stored in the view properties."""
        h = QtWidgets.QGridLayout()
        h.addWidget(QtWidgets.QLabel("Scale:"), 0, 0)
        self.scale_combo = QtWidgets.QComboBox()
        self.scale_combo.setSizeAdjustPolicy(QtWidgets.QComboBox.AdjustToMinimumContentsLengthWithIcon)
        self.scale_combo.setMinimumContentsLength(12)
        self.scale_choices = [("percentiles %g-%g (default)" % (colormaps.LOW_PERCENTILE, colormaps.HIGH_PERCENTILE),
                               "Percentile", None), ("k_f to 99.5th percentile", "From k_f", None)]
        self.scale_choices += [("fixed " + name, "Fixed", (lo, hi)) for name, lo, hi in colormaps.SCALE_PRESETS]
        for text, _, _ in self.scale_choices:
            self.scale_combo.addItem(text)
        vobj = self.obj.ViewObject
        current = [i for i, (_, rng, lim) in enumerate(self.scale_choices) if rng == getattr(vobj, "ScaleRange", "")
                   and (lim is None or tuple(lim) == (vobj.ScaleMin, vobj.ScaleMax))]
        if getattr(vobj, "ScaleRange", "") == "Fixed" and not current:
            self.scale_combo.addItem("fixed %g to %g" % (vobj.ScaleMin, vobj.ScaleMax))
            self.scale_choices.append((self.scale_combo.itemText(self.scale_combo.count() - 1), "Fixed",
                                       (vobj.ScaleMin, vobj.ScaleMax)))
            current = [self.scale_combo.count() - 1]
        self.scale_combo.setCurrentIndex(current[0] if current else 0)
        self.linear_check = QtWidgets.QCheckBox("linear")
        self.linear_check.setChecked(getattr(vobj, "ScaleType", "") == "Linear")
        self.scale_combo.currentIndexChanged.connect(lambda *_: self.set_scale())
        self.linear_check.toggled.connect(lambda *_: self.set_scale())
        h.addWidget(self.scale_combo, 0, 1)
        h.addWidget(self.linear_check, 1, 1)
        h.setColumnStretch(1, 1)
        return h

    def set_scale(self, index=None, linear=None):
        """Apply a scale choice (index into scale_choices) and linear/logarithmic."""
        if index is not None:
            self.scale_combo.setCurrentIndex(index)
        if linear is not None:
            self.linear_check.setChecked(linear)
        _, rng, lim = self.scale_choices[self.scale_combo.currentIndex()]
        vobj = self.obj.ViewObject
        if lim is not None:
            vobj.ScaleMin, vobj.ScaleMax = float(lim[0]), float(lim[1])
        vobj.ScaleType = "Linear" if self.linear_check.isChecked() else "Logarithmic"
        vobj.ScaleRange = rng
        vp = self._vp()
        if vp is not None and vp.legend is not None:
            self.legend_widget.set_legend(vp.legend)

    def _vp(self):
        vobj = getattr(self.obj, "ViewObject", None)
        return getattr(vobj, "Proxy", None) if vobj is not None else None

    def set_map(self, mode):
        """Show colour map mode on the hull (one click: the analysis shown, its colour bar
        the one in the 3D view) and its legend here."""
        from .legend import legend_to
        self.obj.ViewObject.ColorMap = mode
        self.obj.ViewObject.Visibility = True
        legend_to([self.obj])
        vp = self._vp()
        if vp is not None and vp.legend is not None:
            self.legend_widget.set_legend(vp.legend)
        self._sync_map_buttons()

    def _sync_map_buttons(self):
        current = getattr(self.obj.ViewObject, "ColorMap", None)
        for mode, b in self.map_buttons.items():
            b.setChecked(mode == current)

    def _face_table(self):
        faces = self.doc["provenance"]["faces"]
        unit = app_analysis.length_unit_label(self.obj)
        whole = self.doc.get("integrals", {}).get("represented_area")
        box = QtWidgets.QGroupBox("Plates: each BRep face on its own")
        v = QtWidgets.QVBoxLayout(box)
        t = QtWidgets.QTableWidget(len(faces), len(FACE_COLUMNS) - 1)
        t.setHorizontalHeaderLabels(list(FACE_COLUMNS[1:]))
        t.verticalHeader().setVisible(False)
        self.face_rows = []
        note = wording.unestablished_faces_note(faces, self.doc.get("validity", {}))
        self.face_note = note
        if note:
            lab = QtWidgets.QLabel(note)
            lab.setWordWrap(True)
            v.addWidget(lab)
        for i, f in enumerate(faces):
            a_c = (f.get("a_C") or {}) if wording.face_value(f, "a_C") is not None else {}
            shown = {k: wording.format_value(wording.face_value(f, k)) for k in ("I_D", "I_D_plus", "I_D_minus")}
            cells = ["Face%d" % f["face"], str(f.get("status", "")), shown["I_D"],
                     wording.format_value(f.get("area_share"), 3), area_text(f.get("area"), unit, whole),
                     f.get("surface_type", ""), shown["I_D_plus"], shown["I_D_minus"]]
            cells += [wording.format_value(a_c.get(n), 3) for n in ("flat", "single", "elliptic", "saddle")]
            for j, text in enumerate(cells[1:]):
                it = _item(text)
                if j == 0:
                    it.setBackground(QtGui.QBrush(QtGui.QColor(wording.status_color(text))))
                    it.setForeground(QtGui.QBrush(QtGui.QColor("white")))
                    it.setToolTip(wording.status_sentence(text))
                t.setItem(i, j, it)
            self.face_rows.append(cells)
        # the face names are the row header, which stays in view when the table scrolls sideways
        t.setVerticalHeaderLabels([r[0] for r in self.face_rows])
        t.verticalHeader().setVisible(True)
        t.resizeColumnsToContents()
        t.setMinimumHeight(min(30 * (len(faces) + 1), 260))
        v.addWidget(t)
        self.face_table = t
        return box

    def _provenance(self):
        d = self.doc
        inp, sw, prov = d.get("input", {}), d.get("software", {}), d.get("provenance", {})
        box = QtWidgets.QGroupBox("Where these numbers come from")
        form = QtWidgets.QFormLayout(box)
        form.setRowWrapPolicy(QtWidgets.QFormLayout.WrapAllRows)  # each value under its name, full width
        units = prov.get("units")
        rows = [
            ("backend", "%s (%s)" % (self.obj.Backend, "native surface integrals" if self.obj.Representation == "brep"
                                     else "discrete curvature on triangles")),
            ("file", inp.get("path") or "FreeCAD object %s" % inp.get("name", "")),
            ("sha256", inp.get("sha256") or "\u2014 (in-memory shape)"),
            ("units", units_text(units, app_analysis.length_unit_label(self.obj))),
            ("L_ref", "%s: %s" % (d["reference_length"]["mode"], d["reference_length"]["method"])),
            ("faces used", ", ".join("Face%d" % f for f in inp.get("faces_used") or []) or "all"),
            ("software", ", ".join("%s %s" % (k, v) for k, v in sw.items() if v and k != "package")),
            ("run time", "%.2f s" % self.obj.ComputeSeconds),
        ]
        if prov.get("curvature_method"):
            rows.append(("curvature", prov["curvature_method"]))
        prep = prov.get("preparation") or {}
        if prep:  # mesh: what was welded, removed or flipped before the curvature
            rows.append(("mesh preparation", ", ".join("%s %s" % (k.replace("_", " "), v) for k, v in prep.items()
                                                        if isinstance(v, (int, float)) and not isinstance(v, bool))))
        for w in d.get("warnings") or []:
            rows.append(("warning", w))
        self.provenance_rows = rows
        for k, v in rows:
            text = str(v)
            tip = None
            if k == "sha256" and len(text) == 64:  # a hex digest does not wrap: four lines of 16
                tip, text = text, "\n".join(text[i:i + 16] for i in range(0, 64, 16))
            if k == "file":  # a path may wrap after each folder
                tip, text = text, text.replace("/", "/\u200b").replace("\\", "\\\u200b")
            lab = QtWidgets.QLabel(text)
            if tip:
                lab.setToolTip(tip)
            lab.setWordWrap(True)
            lab.setTextInteractionFlags(QtCore.Qt.TextSelectableByMouse)
            form.addRow("<b>%s</b>" % k, lab)
        return box

    def _buttons(self):
        h = QtWidgets.QHBoxLayout()
        copy = QtWidgets.QPushButton("Copy JSON")
        copy.setToolTip("copy the full JSON document of this analysis to the clipboard")
        copy.clicked.connect(self.copy_json)
        detail = QtWidgets.QPushButton("Technical detail")
        detail.setCheckable(True)
        detail.setToolTip("show the whole JSON document as an expandable tree")
        detail.toggled.connect(lambda on: self.tree.setVisible(on))
        h.addWidget(copy)
        h.addWidget(detail)
        self.detail_button = detail
        return h

    def copy_json(self):
        QtWidgets.QApplication.clipboard().setText(self.obj.ResultJSON)
        return self.obj.ResultJSON


def show_validity_panel(obj):
    """Open the panel for analysis obj in the task view (closing another open task)."""
    from .on_screen import show_task_panel
    return show_task_panel(ValidityPanel(obj))
