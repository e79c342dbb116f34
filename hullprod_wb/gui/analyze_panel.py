"""Analyze task panel: L_ref (automatic or explicit), h_f, k_f, planar faces and, under
'advanced', the BRep quadrature settings.

Each source is assessed in an assessment process (app.assessment_process), started when
the panel opens: it receives the shape, loads what the run needs and proposes the
automatic L_ref by the run's own method. OK starts the runs; a Qt timer reads their
progress, so the GUI stays responsive; Cancel ends the running process at once.
"""
import time

from ..app import preferences
from ..app.analysis import make_analysis, record_planar
from ..app.assessment_process import AssessmentProcess, WorkerFailed
from ..app.planar import planar_faces
from ..brep.validity.budget import FACE_POINT_FLOOR, PROTOCOLS
from ..core.errors import InputError
from . import dialogs
from .qt import QtCore, QtGui, QtWidgets

#: The last panel opened (scripts and tests drive it).
LAST_PANEL = None
#: Interval of the timer that reads the assessment processes (ms).
POLL_MS = 40
#: Least time between two repaints of the progress (seconds).
UI_INTERVAL = 0.25
#: The panel offers the whole shape's span when it differs from the selected faces' by more.
WHOLE_SPAN_NOTE = 1e-3


def _float_edit(value, tip, chars=12):
    e = QtWidgets.QLineEdit("%.12g" % value)
    v = QtGui.QDoubleValidator(0.0, 1e300, 12, e)
    v.setNotation(QtGui.QDoubleValidator.ScientificNotation)
    e.setValidator(v)
    e.setToolTip(tip)
    e.setMinimumWidth(e.fontMetrics().averageCharWidth() * chars + 16)
    return e


def _describe(obj, faces):
    kind = "Part" if hasattr(obj, "Shape") else "Mesh"
    part = ", faces %s" % ", ".join("Face%d" % f for f in faces) if faces else ""
    return "%s (%s%s)" % (obj.Label, kind, part)


def _units(obj):
    return "mm" if hasattr(obj, "Shape") else "mesh units"


class AnalyzePanel:
    """Task panel. sources: [(object, faces or None)]; ignored: sub-element names of the
    selection that select nothing to assess (edges, vertices)."""

    def __init__(self, sources, ignored=()):
        global LAST_PANEL
        LAST_PANEL = self
        self.sources = list(sources)
        self.created = []
        self.errors = []
        self.running = None  # index of the source being assessed
        self.queue = []
        self.close_when_done = False
        self.run_seconds = None
        self.processes = [None] * len(self.sources)
        d = preferences.analysis_defaults()
        self.form = QtWidgets.QWidget()
        self.form.setWindowTitle("HullProd: analyse")
        lay = QtWidgets.QVBoxLayout(self.form)
        self._add_sources(lay, ignored)
        self._add_run_state(lay)
        self._add_lref_box(lay)
        self._add_tolerances(lay, d)
        self._add_planar_choice(lay)
        self._add_quadrature(lay, d)
        lay.addStretch(1)
        self._start_runs()

    def _add_sources(self, lay, ignored):
        """What is assessed, and the selected sub-elements that are not."""
        src = QtWidgets.QLabel("<b>Assess</b><br>" + "<br>".join(_describe(o, f) for o, f in self.sources))
        src.setWordWrap(True)
        lay.addWidget(src)
        self.ignored_label = QtWidgets.QLabel()
        self.ignored_label.setWordWrap(True)
        if ignored:
            self.ignored_label.setText("<small>Not assessed (only faces are): %s</small>"
                                       % ", ".join(ignored))
        self.ignored_label.setVisible(bool(ignored))
        lay.addWidget(self.ignored_label)

    def _add_run_state(self, lay):
        """Progress bar and message, near OK and Cancel: in view however tall the settings
        below grow (the task view scrolls)."""
        self.bar = QtWidgets.QProgressBar()
        self.bar.setRange(0, 1000)
        self.bar.setValue(0)
        self.message = QtWidgets.QLabel("Press OK to run; Cancel (or Esc) stops a running analysis.")
        self.message.setWordWrap(True)
        lay.addWidget(self.bar)
        lay.addWidget(self.message)

    def _add_lref_box(self, lay):
        """L_ref: automatic (principal-axis span) or explicit."""
        box = QtWidgets.QGroupBox("Reference length L_ref")
        g = QtWidgets.QGridLayout(box)
        units = _units(self.sources[0][0])
        self.auto_radio = QtWidgets.QRadioButton("automatic: computing...")
        self.auto_radio.setToolTip("principal-axis span of the assessed surface (the run's own method)")
        self.explicit_radio = QtWidgets.QRadioButton("explicit (e.g. L_pp):")
        self.lref_edit = _float_edit(1.0, "L_ref in the source's length units (FreeCAD Part shapes: mm)")
        self.lref_edit.setText("")
        self.lref_unit = QtWidgets.QLabel(units)
        self.auto_radio.setChecked(True)
        self.lref_edit.setEnabled(False)
        self.explicit_radio.toggled.connect(self.lref_edit.setEnabled)
        self.method_label = QtWidgets.QLabel("<small>method: principal-axis span of the surface's area, "
                                             "from a tessellation</small>")
        self.method_label.setWordWrap(True)
        self.whole_note = QtWidgets.QLabel()
        self.whole_note.setWordWrap(True)
        self.whole_note.setVisible(False)
        self.whole_button = QtWidgets.QPushButton("Use the whole shape's span")
        self.whole_button.setVisible(False)
        self.whole_button.clicked.connect(self.use_whole_span)
        g.addWidget(self.auto_radio, 0, 0, 1, 3)
        g.addWidget(self.method_label, 1, 0, 1, 3)
        g.addWidget(self.whole_note, 2, 0, 1, 3)
        g.addWidget(self.whole_button, 3, 0, 1, 3)
        g.addWidget(self.explicit_radio, 4, 0, 1, 3)  # the value beneath: the box fits a narrow task view
        g.addWidget(self.lref_edit, 5, 0, 1, 2)
        g.addWidget(self.lref_unit, 5, 2)
        lay.addWidget(box)

    def _add_tolerances(self, lay, d):
        """The class tolerances h_f, k_f (tau_H = h_f / L_ref, tau_K = k_f / L_ref^2)."""
        box = QtWidgets.QGroupBox("Curvature-class tolerances")
        f = QtWidgets.QFormLayout(box)
        f.setRowWrapPolicy(QtWidgets.QFormLayout.WrapLongRows)
        self.hf_edit = _float_edit(d["h_f"], "dimensionless mean-curvature tolerance; tau_H = h_f / L_ref")
        self.kf_edit = _float_edit(d["k_f"], "dimensionless Gaussian-curvature tolerance; tau_K = k_f / L_ref^2")
        f.addRow("h_f", self.hf_edit)
        f.addRow("k_f", self.kf_edit)
        lay.addWidget(box)

    def _add_planar_choice(self, lay):
        """Leave out planar faces (deck, transom), naming them."""
        self.planar_check = QtWidgets.QCheckBox("Leave out planar faces")
        self.planar_check.setToolTip("faces that lie in a plane (deck, transom) are not assessed; "
                                     "the result records them")
        self.planar = [planar_faces(o.Shape, f) if hasattr(o, "Shape") else [] for o, f in self.sources]
        n_planar = sum(len(p) for p in self.planar)
        self.planar_label = QtWidgets.QLabel()
        self.planar_label.setWordWrap(True)
        if n_planar:
            self.planar_label.setText("<small>planar: %s</small>" % ", ".join("Face%d" % n for p in self.planar for n in p))
        self.planar_label.setVisible(bool(n_planar))
        self.planar_check.setEnabled(bool(n_planar))
        lay.addWidget(self.planar_check)
        lay.addWidget(self.planar_label)

    def _add_quadrature(self, lay, d):
        """Advanced BRep quadrature settings (order, tolerance, protocol, budget, depths)."""
        self.advanced = QtWidgets.QGroupBox("BRep quadrature")
        self.advanced.setToolTip("advanced: tick to set the quadrature of BRep faces yourself")
        self.advanced.setCheckable(True)
        self.advanced.setChecked(False)
        inner = QtWidgets.QWidget()
        f = QtWidgets.QFormLayout(inner)
        f.setRowWrapPolicy(QtWidgets.QFormLayout.WrapLongRows)  # a label above its field when narrow
        self.order_spin = QtWidgets.QSpinBox()
        self.order_spin.setRange(1, 30)
        self.order_spin.setValue(int(d["order"]))
        self.rtol_edit = _float_edit(d["rtol"], "local relative tolerance of the adaptive quadrature")
        self.protocol_combo = QtWidgets.QComboBox()
        self.protocol_combo.addItems(list(PROTOCOLS))
        self.protocol_combo.setCurrentIndex(max(0, self.protocol_combo.findText(str(d["protocol"]))))
        self.protocol_combo.setToolTip(
            "budget: cells refined where the error estimates are largest, within the point budget, "
            "until the shape's totals meet the tolerance\npaper: every face refined to the maximum "
            "depth on its own and rechecked one level deeper (the paper's campaign)")
        self.budget_spin = QtWidgets.QSpinBox()
        self.budget_spin.setRange(FACE_POINT_FLOOR, 2 ** 31 - 1)
        self.budget_spin.setSingleStep(1_000_000)
        self.budget_spin.setGroupSeparatorShown(True)
        self.budget_spin.setValue(int(d["point_budget"]))
        self.budget_spin.setToolTip("field points of the whole assessment, shared by the faces by area "
                                    "(each face at least %d)" % FACE_POINT_FLOOR)
        self.depth_limit_spin = QtWidgets.QSpinBox()
        self.depth_limit_spin.setRange(1, 60)
        self.depth_limit_spin.setValue(int(d["depth_limit"]))
        self.depth_limit_spin.setToolTip("levels a cell may be refined below its surface patch")
        self.depth_spin = QtWidgets.QSpinBox()
        self.depth_spin.setRange(0, 20)
        self.depth_spin.setValue(int(d["max_depth"]))
        self.depth_spin.setToolTip("depth every face is refined to (rechecked one level deeper)")
        self.order_spin.setToolTip("Gauss-Legendre points per direction of a cell")
        f.addRow("Gauss-Legendre order", self.order_spin)
        f.addRow("relative tolerance", self.rtol_edit)
        f.addRow("protocol", self.protocol_combo)
        f.addRow("point budget", self.budget_spin)
        f.addRow("depth limit", self.depth_limit_spin)
        f.addRow("maximum depth", self.depth_spin)
        self.quadrature_form = f
        self.protocol_combo.currentIndexChanged.connect(self._show_protocol_rows)
        self._show_protocol_rows()
        v = QtWidgets.QVBoxLayout(self.advanced)
        v.addWidget(inner)
        inner.setVisible(False)
        self.advanced.toggled.connect(inner.setVisible)
        if not any(hasattr(o, "Shape") for o, _ in self.sources):
            self.advanced.setEnabled(False)
            self.advanced.setToolTip("meshes are assessed by discrete curvature; no quadrature")
        lay.addWidget(self.advanced)

    def _start_runs(self):
        """Poll timer; an assessment process per source, closed with the form."""
        self.timer = QtCore.QTimer(self.form)
        self.timer.setInterval(POLL_MS)
        self.timer.timeout.connect(self.poll)
        # the task view deletes the form when the panel closes, whichever way it closes
        procs = self.processes
        self.form.destroyed.connect(lambda *_: [p.close() for p in procs if p is not None])
        for i in range(len(self.sources)):
            self._start_process(i)
        self.timer.start()

    # -- assessment processes -----------------------------------------------------------------
    def _start_process(self, i):
        obj, faces = self.sources[i]
        try:
            self.processes[i] = AssessmentProcess(obj, faces)
        except InputError as exc:
            self.processes[i] = None
            self.errors.append(str(exc))
            self.message.setText(str(exc))

    def _proposal_text(self):
        parts = []
        for (obj, _), proc in zip(self.sources, self.processes):
            if proc is None or proc.lref is None:
                parts.append("computing..." if proc is not None and proc.state == "loading" else "not available")
            else:
                parts.append("%.6g %s" % (proc.lref, _units(obj)))
        return "automatic: " + "; ".join(parts)

    def _on_loaded(self, i):
        proc = self.processes[i]
        self.auto_radio.setText(self._proposal_text())
        if i != 0 or proc.lref is None:
            if i == 0 and proc.load_error:
                self.method_label.setText("<small>%s</small>" % proc.load_error)
            return
        if not self.lref_edit.text():
            self.lref_edit.setText("%.6g" % proc.lref)
        faces = self.sources[0][1]
        if faces and proc.lref_whole and abs(proc.lref_whole - proc.lref) > WHOLE_SPAN_NOTE * proc.lref_whole:
            u = _units(self.sources[0][0])
            self.whole_note.setText("<small>The automatic L_ref is the span of the selected faces only "
                                    "(%.6g %s); the whole shape spans %.6g %s.</small>"
                                    % (proc.lref, u, proc.lref_whole, u))
            self.whole_button.setText("Use the whole shape's span (%.6g %s)" % (proc.lref_whole, u))
            self.whole_note.setVisible(True)
            self.whole_button.setVisible(True)

    def use_whole_span(self):
        proc = self.processes[0]
        if proc is not None and proc.lref_whole:
            self.explicit_radio.setChecked(True)
            self.lref_edit.setText("%.12g" % proc.lref_whole)

    def poll(self):
        """Timer: read every process's events; finish or start runs."""
        for i, proc in enumerate(list(self.processes)):
            if proc is None or proc is not self.processes[i]:
                continue
            events = proc.poll()
            if any(ev.get("event") == "loaded" or (ev.get("event") == "error" and proc.load_error) for ev in events):
                self._on_loaded(i)
            if i == self.running:
                last = [ev for ev in events if ev.get("event") == "progress"][-1:]
                if last:
                    self._show_progress(i, last[0])
                if proc.finished:
                    self._finish(i)

    def _show_progress(self, i, ev):
        """The latest progress and its message on the bar, repainted only when they change
        and at most every UI_INTERVAL seconds. The message is the bar's text, not the label
        below: a new text in the word-wrapped label lays the whole task view out again,
        which took more CPU than the rest of the GUI during a run."""
        now = time.monotonic()
        value = int(1000 * max(0.0, min(1.0, ev["fraction"])))
        text = "%s: %s  %%p%%" % (self.sources[i][0].Label, ev["message"].replace("%", "%%"))
        if now - getattr(self, "_shown_at", 0.0) < UI_INTERVAL and value < 1000:
            return
        self._shown_at = now
        if value != self.bar.value():
            self.bar.setValue(value)
        if text != self.bar.format():
            self.bar.setFormat(text)

    def _show_protocol_rows(self, *_):
        """The settings of the chosen protocol only: point budget and depth limit under
        budget, the maximum depth under paper."""
        paper = self.protocol_combo.currentText() == "paper"
        for widget, shown in ((self.budget_spin, not paper), (self.depth_limit_spin, not paper),
                              (self.depth_spin, paper)):
            widget.setVisible(shown)
            label = self.quadrature_form.labelForField(widget)
            if label is not None:
                label.setVisible(shown)

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
                   max_depth=self.depth_spin.value(), protocol=self.protocol_combo.currentText(),
                   point_budget=self.budget_spin.value(), depth_limit=self.depth_limit_spin.value())
        return out

    @staticmethod
    def _options(kw, obj):
        opts = {"lref": kw["lref"], "h_f": kw["h_f"], "k_f": kw["k_f"]}
        if hasattr(obj, "Shape"):
            opts.update({k: kw[k] for k in ("order", "rtol", "max_depth", "protocol", "point_budget", "depth_limit")})
        return opts

    # -- run --------------------------------------------------------------------------------------
    def start(self):
        """Start assessing every source (one after the other); False on a bad setting."""
        if self.running is not None:
            return False
        try:
            self.kw = self.values()
        except InputError as exc:
            dialogs.error("invalid setting", str(exc))
            return False
        self.skip_planar = self.planar_check.isChecked()
        self.queue = list(range(len(self.sources)))
        self.made = []
        self.t_start = time.perf_counter()
        self._next()
        return True

    def _next(self):
        while self.queue:
            i = self.queue.pop(0)
            obj, faces = self.sources[i]
            proc = self.processes[i]
            if proc is None or proc.state not in ("loading", "loaded"):  # used or gone: a fresh one
                if proc is not None:
                    proc.close()
                self._start_process(i)
                proc = self.processes[i]
            if proc is None:
                continue
            if self.skip_planar and self.planar[i]:
                chosen = [f for f in (faces or range(1, len(obj.Shape.Faces) + 1)) if f not in self.planar[i]]
                if not chosen:
                    self.errors.append("every face of %s is planar" % obj.Label)
                    dialogs.error("analysis of %s" % obj.Label, "every face is planar: nothing is left to assess")
                    continue
                if chosen != (faces or list(range(1, len(obj.Shape.Faces) + 1))):
                    proc.close()  # the process loaded other faces: a fresh one for these
                    proc = self.processes[i] = AssessmentProcess(obj, chosen)
            self.running = i
            self.bar.setValue(0)
            self.message.setText("%s: running; Cancel (or Esc) stops it." % obj.Label)
            proc.run(self._options(self.kw, obj))
            return
        self._all_done()

    def _finish(self, i):
        obj, faces = self.sources[i]
        proc = self.processes[i]
        self.running = None
        self.bar.setFormat("%p%")
        if proc.state == "cancelled":
            proc.close()
            self.processes[i] = None
            self.queue = []
            self.message.setText("Cancelled: no analysis was created for %s." % obj.Label)
            self.bar.setValue(0)
            self._all_done(cancelled=True)
            return
        started = getattr(proc, "started_at", self.t_start)
        self.timeline = {"process_seconds": proc.seconds, "noticed_after": time.perf_counter() - started,
                         "done_after": getattr(proc, "done_at", float("nan")) - started}
        done = getattr(proc, "done_event", None) or {}
        for key in ("jobs", "threads_at_start"):
            if done.get(key) is not None:
                self.timeline["worker_" + key] = done[key]
        for key, value in (done.get("timings") or {}).items():
            self.timeline["worker_" + key] = value
        try:
            a = proc.result()
            self.timeline["result_loaded_after"] = time.perf_counter() - started
            record_planar(a, self.planar[i] if self.skip_planar else [])
            made = make_analysis(obj, faces=faces, skip_planar=self.skip_planar and bool(self.planar[i]),
                                 assessment=(a, proc.seconds or 0.0), **self.kw)
        except WorkerFailed as exc:
            import FreeCAD  # the traceback goes to the log, for a bug report
            FreeCAD.Console.PrintLog("HullProd: internal error in the assessment of %s: %s\n" % (obj.Label, exc))
            self.errors.append(str(exc).splitlines()[0])
            dialogs.error("analysis of %s failed" % obj.Label, "internal error: %s" % str(exc).splitlines()[0])
        except Exception as exc:  # the input's fault: a clear message, never a crash
            self.errors.append(str(exc))
            dialogs.error("analysis of %s failed" % obj.Label, " ".join(str(exc).split()))
        else:
            self.timeline["analysis_made_after"] = time.perf_counter() - started
            self.made.append(made)
            if preferences.get("HideSourceOnAnalyze") and getattr(obj, "ViewObject", None) is not None:
                obj.ViewObject.Visibility = False
        finally:
            proc.close()
            self.processes[i] = None
        self._next()

    def _all_done(self, cancelled=False):
        import FreeCADGui
        made = getattr(self, "made", [])
        self.created += made
        self.run_seconds = time.perf_counter() - self.t_start
        if hasattr(self, "timeline"):
            self.timeline["all_done"] = self.run_seconds
        if made:
            from .legend import legend_to
            legend_to(made[-1:])
            # nothing stays selected: the selection highlight would tint the colour map
            FreeCADGui.Selection.clearSelection()
            view = getattr(FreeCADGui.ActiveDocument, "ActiveView", None)
            if view is not None and hasattr(view, "fitAll"):
                view.fitAll()
            self.message.setText("Done: %s in %.1f s." % (", ".join(a.Label for a in made), self.run_seconds))
            self.bar.setValue(1000)
        if self.close_when_done and not cancelled and (made or not self.errors):
            self.close_when_done = False
            QtCore.QTimer.singleShot(0, lambda: self._close_and_show(made))

    def _close_and_show(self, made):
        import FreeCADGui
        FreeCADGui.Control.closeDialog()
        if len(made) == 1:
            from .validity_panel import show_validity_panel
            show_validity_panel(made[0])

    def run(self, timeout=None):
        """Assess every source and wait, the event loop running (macros and tests);
        returns the analyses created. Errors go to dialogs.error."""
        if not self.start():
            return []
        t = time.monotonic()
        while self.running is not None:
            QtWidgets.QApplication.processEvents(QtCore.QEventLoop.AllEvents, 20)
            self.poll()
            if timeout is not None and time.monotonic() - t > timeout:
                self.cancel()
            if self.running is not None:  # sleep in the wait for the process's next event
                proc = self.processes[self.running]
                if proc is not None:
                    select_wait(proc, 0.02)
        return list(self.made)

    def cancel(self):
        """End the running assessment now (no analysis is created for it)."""
        if self.running is not None:
            self.processes[self.running].cancel()
            self.poll()

    # -- task panel buttons ---------------------------------------------------------------------
    def accept(self):
        """OK: start the runs; the panel closes itself when they are done."""
        if self.running is None:
            self.close_when_done = self.start()
        return False

    def reject(self):
        """Cancel: stop a running analysis (the panel stays open, saying so), else close."""
        if self.running is not None:
            self.cancel()
            return False
        self.close()
        return True

    def close(self):
        self.timer.stop()
        for proc in self.processes:
            if proc is not None:
                proc.close()


def select_wait(proc, seconds):
    """Sleep until the process writes or seconds pass (the GUI's process takes no CPU)."""
    import select
    try:
        select.select([proc.proc.stdout], [], [], seconds)
    except (ValueError, OSError):  # closed meanwhile
        pass


def show_analyze_panel(sources, ignored=()):
    from .on_screen import show_task_panel
    return show_task_panel(AnalyzePanel(sources, ignored))
