# GUI checks of the HullProd workbench, run inside the real FreeCAD (xvfb-run -a freecad <this file>).
# Environment: HULLPROD_GUI_RESULT (JSON written here), HULLPROD_SCREENSHOTS (PNG folder),
# HULLPROD_SHARED_HULLS (public hull folder, may be absent), HULLPROD_WORK (scratch folder).
# Every check records into RESULT; the pytest side (tests/test_gui.py) asserts on it.
import json
import os
import subprocess
import sys
import time
import traceback

RESULT = {"steps": {}, "errors": [], "timings": {}}
OUT = os.environ.get("HULLPROD_GUI_RESULT", "/tmp/hullprod_gui_result.json")
SHOTS = os.environ.get("HULLPROD_SCREENSHOTS", "/tmp/hullprod_screenshots")
SHARED = os.environ.get("HULLPROD_SHARED_HULLS", "")
WORK = os.environ.get("HULLPROD_WORK", "/tmp/hullprod_gui_work")
T0 = time.time()


#: HULLPROD_GUI_ONLY=workbench,compare runs only the named checks (while working on them).
ONLY = [n for n in os.environ.get("HULLPROD_GUI_ONLY", "").split(",") if n]


def step(name):
    """Decorator: run a check, record its result dict or its traceback."""
    def wrap(func):
        if ONLY and name not in ONLY:
            RESULT["steps"][name] = {"skipped": "not selected (HULLPROD_GUI_ONLY)"}
            return func
        t = time.time()
        try:
            RESULT["steps"][name] = func() or {"ok": True}
        except Exception:
            RESULT["steps"][name] = {"exception": traceback.format_exc()}
        RESULT["timings"][name] = round(time.time() - t, 2)
        return func
    return wrap


def finish():
    RESULT["total_seconds"] = round(time.time() - T0, 2)
    with open(OUT, "w") as fh:
        json.dump(RESULT, fh, indent=1, default=str)
    sys.stdout.flush()
    os._exit(0)


try:
    import numpy as np
    import FreeCAD
    import FreeCADGui
    import Mesh
    from hullprod_wb.gui.qt import QtCore, QtGui, QtWidgets
    from hullprod_wb.gui import selftest
    from hullprod_wb.gui.on_screen import seen_by_a_person
    from hullprod_wb.selftest import source_fingerprint as fingerprint
    import hullprod_wb
    RESULT["package"] = os.path.realpath(os.path.dirname(hullprod_wb.__file__))
    os.makedirs(SHOTS, exist_ok=True)
    os.makedirs(WORK, exist_ok=True)
except Exception:
    RESULT["errors"].append(traceback.format_exc())
    finish()


def process(ms=50):
    end = time.time() + ms / 1000.0
    while time.time() < end:
        QtWidgets.QApplication.processEvents()


def view():
    return FreeCADGui.ActiveDocument.ActiveView


def hull_camera(yaw=30.0, pitch=20.0):
    """Rear view (the +y, starboard side, z up), turned by yaw about z and pitch about the
    camera's horizontal axis (negative: from below, showing the bilge)."""
    v = view()
    v.setCameraType("Orthographic")
    v.viewRear()
    r = v.getCameraOrientation()
    z = FreeCAD.Rotation(FreeCAD.Vector(0, 0, 1), yaw)
    x = FreeCAD.Rotation(FreeCAD.Vector(1, 0, 0), pitch)
    v.setCameraOrientation(z.multiply(r).multiply(x))
    v.fitAll()
    process(50)


def shot(name, w=1000, h=620):
    FreeCADGui.Selection.clearSelection()  # no green selection highlight on the colours
    process(20)
    path = os.path.join(SHOTS, name + ".png")
    view().saveImage(path, w, h, "White")
    return path


def widget_in_view(widget):
    """True when widget is shown whole: inside the viewport of every scroll area it sits in
    (the task view scrolls) and inside the main window."""
    if not widget.isVisible():
        return False
    rect = QtCore.QRect(widget.mapToGlobal(QtCore.QPoint(0, 0)), widget.size())
    parent = widget.parentWidget()
    while parent is not None:
        if isinstance(parent, QtWidgets.QAbstractScrollArea):
            vp = parent.viewport()
            if not QtCore.QRect(vp.mapToGlobal(QtCore.QPoint(0, 0)), vp.size()).contains(rect):
                return False
        parent = parent.parentWidget()
    mw = FreeCADGui.getMainWindow()
    return QtCore.QRect(mw.mapToGlobal(QtCore.QPoint(0, 0)), mw.size()).contains(rect)


def window_shot(name, panel=None):
    """The main window as a person sees it: the window grabbed, the 3D view's own image
    pasted over its area (GL contents do not grab), then the widgets FreeCAD 1.x draws
    over the 3D view (overlay docks, e.g. the task panel in "OverlayRight") on top.
    panel: a widget the picture should show; its rectangle in the picture and its own
    grab are recorded (RESULT["panel_in_shot"]) for the test to compare."""
    FreeCADGui.Selection.clearSelection()
    mw = FreeCADGui.getMainWindow()
    process(100)
    pix = mw.grab()
    mdi = mw.findChild(QtWidgets.QMdiArea)
    sub = mdi.activeSubWindow() if mdi is not None else None
    painted = []
    if sub is not None:
        w = sub.widget()
        pos = w.mapTo(mw, QtCore.QPoint(0, 0))
        tmp = os.path.join(WORK, "view_for_window.png")
        view().saveImage(tmp, w.width(), w.height(), "Current")
        painter = QtGui.QPainter(pix)
        painter.drawImage(pos, QtGui.QImage(tmp))
        for over in over_the_view(mw, w):
            painter.drawPixmap(over.mapTo(mw, QtCore.QPoint(0, 0)), over.grab())
            painted.append(over.objectName())
        painter.end()
    path = os.path.join(SHOTS, name + ".png")
    pix.save(path)
    RESULT.setdefault("overlays_painted", {})[name] = painted
    if panel is not None:
        own = os.path.join(WORK, name + "_panel.png")
        own_pix = panel.grab()
        own_pix.save(own)
        from hullprod_wb.gui.on_screen import visible_rect
        clip = visible_rect(panel)  # the part not scrolled or clipped away
        at, inner = mw.mapFromGlobal(clip.topLeft()), panel.mapFromGlobal(clip.topLeft())
        k, kp = pix.width() / mw.width(), own_pix.width() / panel.width()  # image pixels per widget pixel
        RESULT.setdefault("panel_in_shot", {})[name] = {
            "rect": [round(v * k) for v in (at.x(), at.y(), clip.width(), clip.height())],
            "offset": [round(inner.x() * kp), round(inner.y() * kp)], "scale": [k, kp], "grab": own}
    return path


def over_the_view(mw, view_widget):
    """Shown widgets drawn over the 3D view widget that are not part of it: FreeCAD's
    overlay tab widgets (objectName Overlay*), outermost only."""
    area = QtCore.QRect(view_widget.mapTo(mw, QtCore.QPoint(0, 0)), view_widget.size())
    found = [o for o in mw.findChildren(QtWidgets.QWidget) if o.objectName().startswith("Overlay") and o.isVisible()
             and not o.isAncestorOf(view_widget) and not view_widget.isAncestorOf(o)
             and QtCore.QRect(o.mapTo(mw, QtCore.QPoint(0, 0)), o.size()).intersects(area)]
    return [o for o in found if not any(p is not o and p.isAncestorOf(o) for p in found)]


def wait_for(cond, seconds):
    """Run the event loop until cond() or seconds passed; returns cond()."""
    end = time.time() + seconds
    while not cond() and time.time() < end:
        QtWidgets.QApplication.processEvents(QtCore.QEventLoop.AllEvents, 20)
        time.sleep(0.005)
    return cond()


def screen_shot(name):
    """The main window as the X server shows it (3D view, navigation cube and all)."""
    FreeCADGui.Selection.clearSelection()
    mw = FreeCADGui.getMainWindow()
    process(200)
    pix = QtGui.QGuiApplication.primaryScreen().grabWindow(mw.winId())
    path = os.path.join(SHOTS, name + ".png")
    pix.save(path)
    return path


def quick_quadrature(p):
    """BRep quadrature through the panel's advanced settings (order 6, rtol 2e-4, budget
    protocol with 2e6 points and depth limit 20, maximum depth 4: not the defaults, so the
    test sees them reach the analysis object). Returns which rows the panel showed under
    each protocol."""
    p.advanced.setChecked(True)
    process(20)
    p.order_spin.setValue(6)
    p.rtol_edit.setText("0.0002")
    rows = {}
    for protocol in ("paper", "budget"):
        p.protocol_combo.setCurrentIndex(p.protocol_combo.findText(protocol))
        process(20)
        rows[protocol] = [name for name, w in (("point budget", p.budget_spin), ("depth limit", p.depth_limit_spin),
                                               ("maximum depth", p.depth_spin)) if w.isVisible()]
    p.budget_spin.setValue(2000000)
    p.depth_limit_spin.setValue(20)
    p.depth_spin.setValue(4)
    return rows


def colour_check(a):
    """Colours in the display object: one per display vertex, and how many distinct."""
    from hullprod_wb.app import analysis_fields
    from hullprod_wb.gui.colormaps import distinct_colors
    vp = a.ViewObject.Proxy
    drawn = vp.coin_colors()
    n = len(analysis_fields(a).points)
    return {"n_points": n, "n_colors": len(drawn), "distinct": distinct_colors(drawn),
            "legend": vp.legend.title, "ticks": [t for _, t in vp.legend.ticks],
            "entries": [t for _, t in vp.legend.entries]}


STATE = {}


@step("workbench")
def _():
    registered = selftest.check_workbench()  # AssertionError if a command is missing
    FreeCADGui.activateWorkbench(selftest.WORKBENCH)  # as a person picks it
    mw = FreeCADGui.getMainWindow()
    mw.resize(1500, 950)
    combo = [d for d in mw.findChildren(QtWidgets.QDockWidget) if d.objectName() in ("Combo View", "ComboView")]
    if combo:
        mw.resizeDocks(combo, [560], QtCore.Qt.Horizontal)
    process(100)
    bars = [tb.objectName() for tb in mw.findChildren(QtWidgets.QToolBar)]
    menus = [m.title() for m in mw.menuBar().findChildren(QtWidgets.QMenu)]
    names = ["HullProd_Analyze", "HullProd_ShowDevelopability", "HullProd_ShowClasses",
             "HullProd_ShowSignedDevelopability", "HullProd_ShowPlates", "HullProd_ValidityPanel",
             "HullProd_Export", "HullProd_Probe", "HullProd_Compare"]
    listed = FreeCADGui.listCommands()
    from hullprod_wb.gui import dialogs
    dialogs.INTERACTIVE = False  # no modal dialog may block the run
    tb = [t for t in mw.findChildren(QtWidgets.QToolBar) if t.objectName() == "HullProd"]
    actions = [a.objectName() or a.text() for a in tb[0].actions()] if tb else []
    return {"active": FreeCADGui.activeWorkbench().name(), "toolbars": bars,
            "has_menu": any("HullProd" in m for m in menus), "commands": {n: n in listed for n in names},
            "toolbar_actions": len([x for x in actions if x]), "registered": registered["commands"],
            "icons": {n: not FreeCADGui.getIcon(n).isNull() for n in ("HullProd_Analyze", "preferences-hullprod")}}


@step("analyze_wigley")
def _():
    from hullprod_wb.examples.builtin import half_wigley_shape
    from hullprod_wb.gui import analyze_panel, dialogs
    doc = FreeCAD.newDocument("HullProdGUI")
    src = doc.addObject("Part::Feature", "HalfWigley")
    src.Shape = half_wigley_shape()
    doc.recompute()
    STATE["doc"], STATE["wigley"] = doc, src
    STATE["wigley_before"] = fingerprint(src)
    hull_camera()
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.runCommand("HullProd_Analyze")  # nothing selected: an error message, no crash
    no_sel = [m for m in dialogs.LOG if m[0] == "error"]
    FreeCADGui.Selection.addSelection(src)
    FreeCADGui.runCommand("HullProd_Analyze")
    process(100)
    p = analyze_panel.LAST_PANEL
    shown = FreeCADGui.Control.activeDialog()
    on_screen = seen_by_a_person(p.form)
    p.explicit_radio.setChecked(True)
    p.lref_edit.setText("1.0")
    defaults = [p.protocol_combo.currentText(), p.budget_spin.value(), p.depth_limit_spin.value()]
    tips = [bool(w.toolTip()) for w in (p.protocol_combo, p.budget_spin, p.depth_limit_spin, p.depth_spin)]
    rows = quick_quadrature(p)
    window_shot("analyze_panel", p.form)
    texts = {"proposal": p.auto_radio.text(), "method": p.method_label.text(),
             "advanced_enabled": p.advanced.isEnabled(), "protocol_rows": rows, "quadrature_defaults": defaults,
             "quadrature_tips": tips}
    made = p.run()
    selected_after = [o.Name for o in FreeCADGui.Selection.getSelection()]
    FreeCADGui.Control.closeDialog()
    a = made[0]
    STATE["a_wigley"] = a
    hull_camera()
    texts["selected_after"] = selected_after
    texts["precision_types"] = [a.getTypeIdOfProperty(n) for n in ("Hf", "Kf", "QuadratureRtol")]
    return {"panel_shown": bool(shown), "no_selection_error": [m[2] for m in no_sel], **texts, "on_screen": on_screen,
            "quadrature": [a.QuadratureOrder, a.QuadratureRtol, a.QuadratureMaxDepth],
            "budget_settings": [a.QuadratureProtocol, a.QuadraturePointBudget, a.QuadratureDepthLimit],
            "run_options": {k: json.loads(a.ResultJSON)["options"].get(k) for k in ("protocol", "point_budget", "depth_limit")},
            "status": a.Status, "representation": a.Representation, "lref": a.LrefUsed,
            "I_D": a.I_D, "I_D_status": a.I_D_Status, "source_visible": src.ViewObject.Visibility}


@step("colour_maps_wigley")
def _():
    a = STATE["a_wigley"]
    out = {}
    for cmd, mode, name in (("HullProd_ShowDevelopability", "Developability", "wigley_developability"),
                            ("HullProd_ShowClasses", "Classes", "wigley_classes"),
                            ("HullProd_ShowSignedDevelopability", "Signed", "wigley_signed"),
                            ("HullProd_ShowPlates", "Plates", "wigley_plates")):
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(a)
        FreeCADGui.runCommand(cmd)
        process(30)
        rec = colour_check(a)
        rec["selected_after"] = [o.Name for o in FreeCADGui.Selection.getSelection()]
        rec["mode"] = a.ViewObject.ColorMap
        rec["png"] = shot(name)
        out[mode] = rec
    return out


@step("verification_menu")
def _():
    from hullprod_wb.gui import dialogs
    a = STATE["a_wigley"]
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(a)
    from hullprod_wb.gui import verification_commands
    before = len(dialogs.LOG)
    FreeCADGui.runCommand("HullProd_StudyThresholds")
    run = verification_commands.LAST_RUN
    wait_for(lambda: run is not None and run.finished, 300)
    msgs = dialogs.LOG[before:]
    report = [m[2].split("\n")[-1] for m in msgs if m[0] == "info"]
    path = report[0] if report else ""
    html = open(path).read() if path and os.path.exists(path) else ""
    return {"commands": [c for c in ("HullProd_StudySameFace", "HullProd_StudyRefinement",
                                     "HullProd_StudyRepresentation", "HullProd_StudyThresholds")
                         if c in FreeCADGui.listCommands()],
            "messages": [list(m) for m in msgs], "report": path, "html_bytes": len(html),
            "has_threshold_table": "1e-05" in html or "1e-5" in html}


@step("validity_panel")
def _():
    a = STATE["a_wigley"]
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(a)
    FreeCADGui.runCommand("HullProd_ShowDevelopability")
    p = selftest.opened_validity_panel(a)
    process(100)
    cells = p.signature_cells()
    copied = p.copy_json()
    clip = QtWidgets.QApplication.clipboard().text()
    p.detail_button.setChecked(True)
    tree_top = p.tree.topLevelItemCount()
    p.detail_button.setChecked(False)
    p.set_map("Classes")
    legend_after_click = p.legend_widget.legend.title
    class_entries = [t for _, t in p.legend_widget.legend.entries]
    bar = FreeCADGui.getMainWindow().findChild(QtWidgets.QToolBar, "HullProd")
    process(700)  # FreeCAD updates the commands' enabled state on a timer
    enabled_while_open = {act.text(): act.isEnabled() for act in bar.actions() if act.text()}
    p.set_map("Developability")
    scale_before = [a.ViewObject.ScaleRange, a.ViewObject.ScaleType]
    p.set_scale(index=3, linear=False)  # the preset 'fixed 1 to 10 000'
    fixed_ticks = [t for _, t in p.legend_widget.legend.ticks]
    p.set_scale(index=0, linear=True)
    linear_title = p.legend_widget.legend.title
    p.set_scale(index=0, linear=False)
    texts = {"areas": p.areas_label.text(), "units_row": dict(p.provenance_rows).get("units"),
             "reason_scrolls": p.signature_table.horizontalScrollBar().isVisible()}
    p.set_map("Developability")
    on_screen = seen_by_a_person(p.form)
    path = window_shot("validity_panel", p.form)
    FreeCADGui.Control.closeDialog()
    return {"rows": cells, "status_colors": [r["color"] for r in p.rows],
            "provenance": [k for k, _ in p.provenance_rows], "face_rows": getattr(p, "face_rows", []),
            "json_copied": copied == a.ResultJSON and clip == a.ResultJSON, "tree_top": tree_top,
            "legend_after_click": legend_after_click, "png": path, "class_entries": class_entries,
            "enabled_while_open": enabled_while_open, "scale_before": scale_before, "fixed_ticks": fixed_ticks,
            "linear_title": linear_title, "on_screen": on_screen, **texts}


@step("probe_wigley")
def _():
    from hullprod_wb.gui import probe
    a = STATE["a_wigley"]
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(a)
    FreeCADGui.runCommand("HullProd_Probe")
    process(50)
    panel = probe.ACTIVE
    from hullprod_wb.examples.builtin import WIGLEY_B, WIGLEY_T
    z = -0.5 * WIGLEY_T
    pt = FreeCAD.Vector(0.1, 0.5 * WIGLEY_B * (1 - 0.2 ** 2) * (1 - 0.25), z)
    x, y = view().getPointOnScreen(pt)
    h = FreeCADGui.getMainWindow().findChild(QtWidgets.QMdiArea).activeSubWindow().widget().height()
    r = None
    tried = []
    for pos in ((x, y), (x, h - y)):  # getPointOnScreen and getObjectInfo may differ in y origin
        tried.append(list(pos))
        r = panel.pick_at(pos)
        if r is not None:
            break
    process(50)
    path = shot("wigley_probe")
    on_screen = seen_by_a_person(panel.form)
    window_shot("probe_panel", panel.form)
    rows = panel.table.rowCount()
    headers = [panel.table.horizontalHeaderItem(j).text() for j in range(panel.table.columnCount())]
    marker_before = a.ViewObject.Proxy.marker_sep.getNumChildren()
    FreeCADGui.Control.closeDialog()
    process(50)
    return {"result": r, "rows": rows, "tried": tried, "target": [pt.x, pt.y, pt.z], "png": path,
            "callback_removed": probe.ACTIVE is None, "headers": headers, "marker_before": marker_before,
            "on_screen": on_screen,
            "marker_after": a.ViewObject.Proxy.marker_sep.getNumChildren()}


@step("mesh_analysis")
def _():
    from hullprod_wb.examples.analytic_meshes import half_wigley_mesh
    from hullprod_wb.gui import analyze_panel, probe
    doc = STATE["doc"]
    V, F = half_wigley_mesh(48, 12)
    m = doc.addObject("Mesh::Feature", "HalfWigleyMesh")
    m.Mesh = Mesh.Mesh(V[F].tolist())
    m.Placement.Base = FreeCAD.Vector(0, 0, -0.15)
    doc.recompute()
    before = fingerprint(m)
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(m)
    FreeCADGui.runCommand("HullProd_Analyze")
    p = analyze_panel.LAST_PANEL
    p.explicit_radio.setChecked(True)
    p.lref_edit.setText("1.0")
    adv = p.advanced.isEnabled()
    made = p.run()
    FreeCADGui.Control.closeDialog()
    a = made[0]
    STATE["a_mesh"] = a
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(a)
    FreeCADGui.runCommand("HullProd_ShowDevelopability")
    cols = colour_check(a)
    from hullprod_wb.gui import dialogs
    n_msg = len(dialogs.LOG)
    FreeCADGui.Selection.addSelection(a)
    FreeCADGui.runCommand("HullProd_ShowPlates")
    plates = {"messages": [m[2] for m in dialogs.LOG[n_msg:]], "map": a.ViewObject.ColorMap}
    FreeCADGui.Selection.addSelection(a)
    FreeCADGui.runCommand("HullProd_Probe")
    from hullprod_wb.app import analysis_fields
    f = analysis_fields(a)
    inner = np.nonzero(np.asarray(f.valid)[f.triangles].all(axis=1))[0]  # corners with valid curvature
    tri = f.triangles[inner[inner.size // 2]]
    r = probe.ACTIVE.probe(a, f.points[tri].mean(axis=0))
    FreeCADGui.Control.closeDialog()
    return {"status": a.Status, "representation": a.Representation, "advanced_enabled": adv,
            "colors": cols, "probe": r, "unchanged": fingerprint(m) == before, "plates": plates}


@step("face_selection")
def _():
    """Faces picked in the 3D view (sub-elements 'FaceN') are the only faces assessed."""
    import Part
    from hullprod_wb.gui import analyze_panel
    doc = STATE["doc"]
    cyl = doc.addObject("Part::Feature", "Cylinder")
    cyl.Shape = Part.makeCylinder(0.02, 0.1, FreeCAD.Vector(0, 0.2, -0.05))
    doc.recompute()
    lateral = [i + 1 for i, f in enumerate(cyl.Shape.Faces) if "Cylinder" in type(f.Surface).__name__][0]
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(cyl, "Face%d" % lateral)
    FreeCADGui.Selection.addSelection(cyl, "Edge1")  # a stray edge: named, not assessed
    FreeCADGui.runCommand("HullProd_Analyze")
    p = analyze_panel.LAST_PANEL
    wait_for(lambda: p.processes[0] is None or p.processes[0].state != "loading", 60)
    ignored = p.ignored_label.text() if p.ignored_label.isVisible() or p.ignored_label.text() else ""
    whole = {"note": p.whole_note.text(), "button": p.whole_button.text(), "shown": not p.whole_note.isHidden()}
    made = p.run()
    FreeCADGui.Control.closeDialog()
    a = made[0]
    out = {"lateral": lateral, "faces": list(a.Faces), "faces_used": list(a.FacesUsed),
           "face_count": len(cyl.Shape.Faces), "a_single": [a.a_single, a.a_single_Status],
           "ignored": ignored, "whole": whole, "lref_selected": a.LrefUsed}
    doc.removeObject(a.Name)
    # the whole cylinder with its two planar caps left out by the checkbox
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(cyl)
    FreeCADGui.runCommand("HullProd_Analyze")
    p = analyze_panel.LAST_PANEL
    out["planar_text"] = QtGui.QTextDocumentFragment.fromHtml(p.planar_label.text()).toPlainText()
    p.planar_check.setChecked(True)
    made = p.run()
    FreeCADGui.Control.closeDialog()
    a = made[0]
    doc_json = json.loads(a.ResultJSON)
    out.update(planar_faces_used=list(a.FacesUsed), planar_recorded=doc_json["input"].get("planar_faces_left_out"),
               planar_property=a.SkipPlanarFaces)
    doc.removeObject(a.Name)
    # a line (no faces) is refused before a panel opens
    from hullprod_wb.gui import dialogs
    import Part
    line = doc.addObject("Part::Feature", "Line")
    line.Shape = Part.LineSegment(FreeCAD.Vector(0, 0, 0), FreeCAD.Vector(1, 0, 0)).toShape()
    doc.recompute()
    before = analyze_panel.LAST_PANEL
    n_err = len(dialogs.LOG)
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(line)
    FreeCADGui.runCommand("HullProd_Analyze")
    out["line_messages"] = [m[2] for m in dialogs.LOG[n_err:]]
    out["line_panel_opened"] = analyze_panel.LAST_PANEL is not before
    doc.removeObject(line.Name)
    cyl.ViewObject.Visibility = False
    return out


@step("legend_layout")
def _():
    """The 3D colour bar in full view, clear of the navigation cube, at two window sizes."""
    from hullprod_wb.gui.legend import legend_to
    a = STATE["a_wigley"]
    a.ViewObject.ColorMap = "Developability"
    legend_to([a])
    hull_camera()
    mw = FreeCADGui.getMainWindow()
    grp = FreeCAD.ParamGet("User parameter:BaseApp/Preferences/View")
    cube = grp.GetInt("NaviWidgetSize", 132)
    corner = grp.GetInt("CornerNaviCube", 1)  # 0 top left, 1 top right, 2 bottom left, 3 bottom right
    from hullprod_wb.gui.legend import overlay_box_pixels
    out = {}
    for w, h in ((1600, 1000), (1280, 720)):
        mw.showNormal()
        mw.resize(w, h)
        process(300)
        widget = mw.findChild(QtWidgets.QMdiArea).activeSubWindow().widget()
        vw, vh = widget.width(), widget.height()
        rec = {"view": [vw, vh], "cube": cube, "corner": corner}
        for mode in ("Developability", "Classes", "Signed"):
            a.ViewObject.ColorMap = mode
            process(50)
            box = overlay_box_pixels(a.ViewObject.Proxy.legend, vw, vh)
            cx0 = 0 if corner in (0, 2) else vw - cube
            cy0 = 0 if corner in (0, 1) else vh - cube
            overlaps = not (box[2] <= cx0 or box[0] >= cx0 + cube or box[3] <= cy0 or box[1] >= cy0 + cube)
            rec[mode] = {"box": [round(b, 1) for b in box], "inside": box[0] >= 0 and box[1] >= 0 and box[2] <= vw
                         and box[3] <= vh, "overlaps_cube": overlaps}
        a.ViewObject.ColorMap = "Developability"
        process(50)
        rec["png"] = screen_shot("legend_%dx%d" % (w, h))
        out["%dx%d" % (w, h)] = rec
    mw.resize(1500, 950)
    process(100)
    return out


@step("compare")
def _():
    from hullprod_wb.gui import compare_panel
    a, b = STATE["a_wigley"], STATE["a_mesh"]
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(a)
    FreeCADGui.Selection.addSelection(b)
    orig = compare_panel.show_compare_panel
    got = {}

    def capture(*args):
        got["panel"] = orig(*args)
        return got["panel"]
    compare_panel.show_compare_panel = capture
    try:
        FreeCADGui.runCommand("HullProd_Compare")
    finally:
        compare_panel.show_compare_panel = orig
    p = got["panel"]
    process(100)
    chart = p.save_chart(os.path.join(SHOTS, "compare_chart.png"))
    win = window_shot("compare_panel")
    out = {"flags": p.cmp["flags"], "columns": p.table.columnCount(), "rows": p.table.rowCount(),
           "chart": chart, "window": win, "pixmap": not p.chart.pixmap().isNull()}
    FreeCADGui.Control.closeDialog()
    return out


@step("export")
def _():
    from hullprod_wb.gui import dialogs
    a = STATE["a_wigley"]
    folder = os.path.join(WORK, "export")
    dialogs.ANSWERS[:] = [folder]
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(a)
    FreeCADGui.runCommand("HullProd_Export")
    target = os.path.join(folder, a.Label)
    files = sorted(os.listdir(target)) if os.path.isdir(target) else []
    return {"files": files, "info": [m[2] for m in dialogs.LOG if m[0] == "info"][-1:]}


@step("errors_and_cancel")
def _():
    from hullprod_wb.gui import analyze_panel, dialogs
    from hullprod_wb.app.progress import RunProgress
    doc, src = STATE["doc"], STATE["wigley"]
    n_err = len([m for m in dialogs.LOG if m[0] == "error"])
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(src)
    FreeCADGui.runCommand("HullProd_Analyze")
    p = analyze_panel.LAST_PANEL
    p.explicit_radio.setChecked(True)
    p.lref_edit.setText("-3")
    bad = p.run()
    p.lref_edit.setText("1.0")
    count = len(doc.Objects)
    # Cancel (the panel's button, or Esc) while the run reports progress.
    p.advanced.setChecked(True)
    p.rtol_edit.setText("1e-9")  # a run far longer than the wait for its first progress
    p.depth_spin.setValue(12)
    p.start()
    wait_for(lambda: p.running is None or p.processes[p.running].last_progress is not None, 30)
    running_on_screen = selftest.running_seen(p) if p.running is not None else None
    p.reject()
    msg = p.message.text()
    cancelled = p.made
    FreeCADGui.Control.closeDialog()
    errors = [m[2] for m in dialogs.LOG if m[0] == "error"][n_err:]
    # Deleting an analysis from the tree shows its hidden source again (when it was the last).
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(src)
    FreeCADGui.runCommand("HullProd_Analyze")
    tmp = analyze_panel.LAST_PANEL
    quick_quadrature(tmp)
    extra = tmp.run()
    FreeCADGui.Control.closeDialog()
    others = [o for o in doc.Objects if getattr(o, "Source", None) == src and o.Name != extra[0].Name]
    src.ViewObject.Visibility = False
    FreeCADGui.Selection.clearSelection()
    extra_name = extra[0].Name
    FreeCADGui.Selection.addSelection(extra[0])
    FreeCADGui.runCommand("Std_Delete")
    process(50)
    source_shown = bool(src.ViewObject.Visibility)
    deleted = doc.getObject(extra_name) is None
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.runCommand("HullProd_Compare")  # nothing selected: every open analysis listed, no crash
    from hullprod_wb.gui import compare_panel
    panel = compare_panel.LAST_PANEL
    compare_listed = len(panel.candidates) if panel is not None else 0
    FreeCADGui.Control.closeDialog()
    return {"bad_created": len(bad), "errors": errors, "cancel_created": len(cancelled),
            "objects_unchanged": len(doc.Objects) == count, "cancel_message": msg, "compare_listed": compare_listed,
            "deleted": deleted, "source_shown_after_delete": source_shown, "other_analyses": len(others),
            "RunProgress": RunProgress.__name__, "running_on_screen": running_on_screen}



def render_clock():
    """A Coin callback in the 3D view's scene that records the time of every redraw."""
    from pivy import coin
    times = []

    def on_action(_, action):
        if action.isOfType(coin.SoGLRenderAction.getClassTypeId()):
            times.append(time.monotonic())
    cb = coin.SoCallback()
    cb.setCallback(on_action)
    view().getSceneGraph().insertChild(cb, 0)
    return times, lambda: view().getSceneGraph().removeChild(cb)


def open_hull(fname, docname):
    """A shared BRep hull as a Part feature in a new document (None when absent)."""
    return open_path(os.path.join(SHARED, "brep", fname), docname) if SHARED else None


def open_path(path, docname):
    """The BRep file at path as a Part feature in a new document (None when absent)."""
    import Part
    if not os.path.isfile(path):
        return None
    doc = FreeCAD.newDocument(docname)
    src = doc.addObject("Part::Feature", docname)
    src.Shape = Part.read(path)
    doc.recompute()
    return src


@step("responsive_cancel")
def _():
    """A long run (KVLCC2, tight quadrature) with the view orbiting: redraws are timed;
    then Cancel, and the assessment process must be gone within a second."""
    from hullprod_wb.gui import analyze_panel, dialogs
    src = open_hull("kvlcc2_half_overture.igs", "kvlcc2")
    if src is None:
        return {"skipped": "public hulls not present"}
    hull_camera()
    n_err = len([m for m in dialogs.LOG if m[0] == "error"])
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(src)
    FreeCADGui.runCommand("HullProd_Analyze")
    p = analyze_panel.LAST_PANEL
    p.advanced.setChecked(True)
    p.rtol_edit.setText("1e-6")
    p.depth_spin.setValue(6)
    times, remove = render_clock()
    turn = QtCore.QTimer()
    turn.timeout.connect(lambda: view().setCameraOrientation(
        FreeCAD.Rotation(FreeCAD.Vector(0, 0, 1), 3).multiply(view().getCameraOrientation())))
    turn.start(50)
    t0 = time.monotonic()
    p.accept()  # OK
    wait_for(lambda: p.running is None, 12)
    running_after = p.running is not None
    t1 = time.monotonic()
    progress_text = p.message.text()
    proposal_while_running = p.auto_radio.text()
    seen_running = selftest.running_seen(p) if running_after else None
    shot_running = window_shot("analyze_running", p.form)
    pid = p.processes[p.running].proc.pid if running_after else None
    tc = time.monotonic()
    p.reject()  # Cancel
    gone = None
    while pid is not None and time.monotonic() - tc < 5:
        try:
            os.kill(pid, 0)
            with open("/proc/%d/stat" % pid) as fh:
                if fh.read().split()[2] == "Z":
                    raise ProcessLookupError
        except (ProcessLookupError, FileNotFoundError):
            gone = time.monotonic() - tc
            break
        time.sleep(0.01)
    turn.stop()
    remove()
    gaps = [b - a for a, b in zip([t0] + times, times + [t1]) if a >= t0 and b <= t1 + 1e-9]
    shot_cancel = window_shot("analyze_cancelled")
    msg = p.message.text()
    message_in_view = {}
    mw = FreeCADGui.getMainWindow()
    for w, h in ((1600, 1000), (1280, 720)):
        mw.showNormal()
        mw.resize(w, h)
        process(300)
        message_in_view["%dx%d" % (w, h)] = widget_in_view(p.message)
    mw.resize(1500, 950)
    process(100)
    FreeCADGui.Control.closeDialog()
    made = [o for o in src.Document.Objects if getattr(o, "Source", None) == src]
    FreeCAD.closeDocument(src.Document.Name)
    return {"run_seconds": round(t1 - t0, 2), "still_running": running_after, "redraws": len(times),
            "max_gap": max(gaps) if gaps else None, "progress_text": progress_text,
            "cancel_seconds": gone, "message": msg, "created": len(made), "proposal": proposal_while_running,
            "errors": [m[2] for m in dialogs.LOG if m[0] == "error"][n_err:],
            "png_running": shot_running, "png_cancelled": shot_cancel, "message_in_view": message_in_view,
            "running_on_screen": seen_running}


def cli_seconds(path):
    """Wall time of `./hullprod analyze --json path` of this checkout, its exit code, its
    last stderr line, and (user+system CPU seconds of it and its face processes, its face
    processes' count "jobs" and per-phase "timings" from the JSON)."""
    import resource
    root = os.path.dirname(RESULT["package"])
    env = dict(os.environ)
    env.pop("PYTHONHOME", None)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    r = subprocess.run([os.path.join(root, "hullprod"), "analyze", "--json", "--quiet", path], env=env,
                       capture_output=True, text=True)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    info = {"cpu": after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime}
    try:
        doc = json.loads(r.stdout)
        info.update(jobs=doc["options"].get("jobs"), timings=doc.get("timings"))
    except (ValueError, KeyError, TypeError):
        pass
    return wall, r.returncode, (r.stderr.strip().splitlines() or [""])[-1], info


#: gui_vs_cli's hulls and runs: shared hulls by name, or absolute paths
#: (HULLPROD_GUI_VS_CLI, a JSON list of [file, runs]; bench/gui_vs_cli.py).
TIMED_HULLS = json.loads(os.environ.get("HULLPROD_GUI_VS_CLI") or "null") or [
    ["dtmb5415_half_overture.igs", 3], ["kcs_full_closed_ohp.iges", 1], ["fcship_half_wavebem.iges", 1]]


@step("gui_vs_cli")
def _():
    """GUI time of Analyze (OK pressed until the analysis is made and coloured) against
    `./hullprod analyze` on shared hulls, all faces, default settings; the two alternate
    (a command-line run before each GUI run) so that both see the same machine."""
    from hullprod_wb.gui import analyze_panel, dialogs
    import resource
    out = {}
    # FreeCAD's own CPU while it only runs its event loop (no run): its share of the cores
    own, t = resource.getrusage(resource.RUSAGE_SELF), time.perf_counter()
    wait_for(lambda: False, 3)
    own_after, idle_wall = resource.getrusage(resource.RUSAGE_SELF), time.perf_counter() - t
    idle = (own_after.ru_utime - own.ru_utime + own_after.ru_stime - own.ru_stime) / idle_wall
    for fname, runs in TIMED_HULLS:
        path = fname if os.path.isabs(fname) else os.path.join(SHARED, "brep", fname)
        src = open_path(path, "timed")
        if src is None:
            out[fname] = {"skipped": "public hulls not present"}
            continue
        rec = {"seconds": [], "cli_seconds": [], "errors": [], "cli_error": None, "idle_cpu_share": idle,
               "faces": len(src.Shape.Faces)}
        for _ in range(runs):
            seconds, code, last, info = cli_seconds(path)
            if code != 0:
                rec["cli_error"] = "exit %d: %s" % (code, last)
            rec["cli_seconds"].append(seconds)
            rec.setdefault("cli_info", []).append(info)
            n_err = len([m for m in dialogs.LOG if m[0] == "error"])
            FreeCADGui.Selection.clearSelection()
            FreeCADGui.Selection.addSelection(src)
            FreeCADGui.runCommand("HullProd_Analyze")
            p = analyze_panel.LAST_PANEL
            wait_for(lambda: p.processes[0] is None or p.processes[0].state != "loading", 60)  # the user reads the panel
            rec["proposal"] = p.auto_radio.text()
            import resource
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            own = resource.getrusage(resource.RUSAGE_SELF)
            made = p.run()
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            own_after = resource.getrusage(resource.RUSAGE_SELF)
            rec.setdefault("gui_cpu", []).append(
                {"worker": after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime,
                 "gui": own_after.ru_utime - own.ru_utime + own_after.ru_stime - own.ru_stime})
            errs = [m[2] for m in dialogs.LOG if m[0] == "error"][n_err:]
            FreeCADGui.Control.closeDialog()
            if errs or not made:
                rec["errors"] += errs or ["no analysis made"]
                break
            rec["seconds"].append(p.run_seconds)
            rec.setdefault("timelines", []).append(getattr(p, "timeline", None))
            rec["I_D"] = made[0].I_D
            rec["lref"] = made[0].LrefUsed
            for a in made:
                src.Document.removeObject(a.Name)
        FreeCAD.closeDocument(src.Document.Name)
        out[fname] = rec
    return out


@step("real_hull")
def _():
    """A public BRep hull through the GUI: DTMB 5415, its two hull faces selected in the
    3D view (not the transom), L_ref = L_pp = 5720 mm."""
    name, fname, faces, lref = "dtmb5415", "dtmb5415_half_overture.igs", ["Face1", "Face2"], "5720"
    brep = os.path.join(SHARED, "brep", fname)
    if not (SHARED and os.path.isfile(brep)):
        return {"skipped": "public hulls not present"}
    import Part
    from hullprod_wb.gui import analyze_panel
    doc = FreeCAD.newDocument(name)
    src = doc.addObject("Part::Feature", name)
    src.Shape = Part.read(brep)
    doc.recompute()
    hull_camera()
    before = fingerprint(src)
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(src, faces)  # the two hull faces, not the transom
    FreeCADGui.runCommand("HullProd_Analyze")
    p = analyze_panel.LAST_PANEL
    wait_for(lambda: p.processes[0] is None or p.processes[0].state != "loading", 60)
    proposal = p.auto_radio.text()
    whole_note = p.whole_note.text() if not p.whole_note.isHidden() else ""
    window_shot("%s_analyze_faces" % name)
    p.explicit_radio.setChecked(True)
    p.lref_edit.setText(lref)
    t = time.time()
    made = p.run()
    seconds = time.time() - t
    FreeCADGui.Control.closeDialog()
    a = made[0]
    hull_camera()
    STATE["a_real"] = a
    out = {"hull": name, "proposal": proposal, "whole_note": whole_note, "faces": list(a.FacesUsed),
           "face_count": len(src.Shape.Faces),
           "selected": faces, "status": a.Status, "seconds": round(seconds, 2), "lref": a.LrefUsed,
           "values": {m: [getattr(a, m), getattr(a, m + "_Status")] for m in
                      ("I_D", "I_D_plus", "I_D_minus", "a_flat", "a_single", "a_elliptic", "a_saddle")},
           "shots": {}}
    for cmd, mode in (("HullProd_ShowDevelopability", "developability"), ("HullProd_ShowClasses", "classes"),
                      ("HullProd_ShowSignedDevelopability", "signed"), ("HullProd_ShowPlates", "plates")):
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(a)
        FreeCADGui.runCommand(cmd)
        out["shots"][mode] = dict(colour_check(a), png=shot("%s_%s" % (name, mode)))
    out["unchanged"] = fingerprint(src) == before
    return out


@step("real_mesh_hull")
def _():
    mesh = os.path.join(SHARED, "mesh", "dtmb5415_full_coarse.stl")
    if not (SHARED and os.path.isfile(mesh)):
        return {"skipped": "public hulls not present"}
    from hullprod_wb.gui import analyze_panel
    doc = FreeCAD.newDocument("DTMB5415_mesh")
    m = doc.addObject("Mesh::Feature", "DTMB5415_mesh")
    m.Mesh = Mesh.Mesh(mesh)
    doc.recompute()
    before = fingerprint(m)
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(m)
    FreeCADGui.runCommand("HullProd_Analyze")
    p = analyze_panel.LAST_PANEL
    made = p.run()
    FreeCADGui.Control.closeDialog()
    b = made[0]
    hull_camera()
    FreeCADGui.Selection.addSelection(b)
    FreeCADGui.runCommand("HullProd_ShowDevelopability")
    dev = dict(colour_check(b), png=shot("dtmb5415_mesh_developability"))
    FreeCADGui.Selection.addSelection(b)
    FreeCADGui.runCommand("HullProd_ShowClasses")
    cls = dict(colour_check(b), png=shot("dtmb5415_mesh_classes"))
    STATE["b_real"] = b
    return {"status": b.Status, "I_D": [b.I_D, b.I_D_Status], "developability": dev, "classes": cls,
            "unchanged": fingerprint(m) == before}


@step("compare_real")
def _():
    """The native DTMB 5415 (two faces, L_ref = L_pp) against its coarse mesh (automatic L_ref)."""
    if "a_real" not in STATE or "b_real" not in STATE:
        return {"skipped": "public hulls not present"}
    from hullprod_wb.gui import compare_panel
    a, b = STATE["a_real"], STATE["b_real"]
    FreeCAD.setActiveDocument(b.Document.Name)
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(b)
    p = compare_panel.show_compare_panel([a, b])
    process(200)
    win = window_shot("dtmb5415_compare")
    out = {"flags": p.cmp["flags"], "window": win}
    FreeCADGui.Control.closeDialog()
    return out


@step("save_reload_gui")
def _():
    doc = STATE["doc"]
    path = os.path.join(WORK, "gui_roundtrip.FCStd")
    a = STATE["a_wigley"]
    name, i_d, mode = a.Name, a.I_D, "Classes"
    a.ViewObject.ColorMap = mode
    doc.saveAs(path)
    FreeCAD.closeDocument(doc.Name)
    d2 = FreeCAD.openDocument(path)
    process(100)
    b = d2.getObject(name)
    vp = b.ViewObject.Proxy
    rec = colour_check(b)
    out = {"I_D_same": b.I_D == i_d, "vp_class": type(vp).__name__, "colors": rec,
           "map": b.ViewObject.ColorMap}
    from hullprod_wb.gui import validity_panel
    b.ViewObject.Visibility = False
    vpanel = validity_panel.show_validity_panel(b)
    vpanel.set_map("Signed")
    process(50)
    out["after_map_button"] = {"visible": b.ViewObject.Visibility, "legend_on": [
        o.Name for o in d2.Objects if "ShowLegend" in getattr(o.ViewObject, "PropertiesList", []) and o.ViewObject.ShowLegend],
        "name": b.Name}
    FreeCADGui.Control.closeDialog()
    FreeCAD.closeDocument(d2.Name)
    return out


@step("plates_low_end_and_samples")
def _():
    """The fore body (part5: flat plates at 1e-12 and faces with collapsed sides) through the
    Analyze panel: the display samples of its VALID and VALID* faces, the not-established
    colour drawn on them under the developability and plate maps, the plate map's low end
    against the face records, and the evidence line of the validity panel."""
    from hullprod_wb.app import analysis_fields, result_document
    from hullprod_wb.app.analysis import length_unit_label
    from hullprod_wb.gui import analyze_panel, colormaps, wording
    src = open_hull("ship_forebody_part5_overture.igs", "forebody_part5")
    if src is None:
        return {"skipped": "public hulls not present"}
    FreeCADGui.activateWorkbench(selftest.WORKBENCH)  # active already unless run alone
    hull_camera()
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(src)
    FreeCADGui.runCommand("HullProd_Analyze")
    p = analyze_panel.LAST_PANEL
    wait_for(lambda: p.processes[0] is None or p.processes[0].state != "loading", 60)
    a = p.run()[0]
    FreeCADGui.Control.closeDialog()
    doc = result_document(a)
    established = [f["face"] for f in doc["provenance"]["faces"] if f["status"] in ("VALID", "VALID*")]
    fields = analysis_fields(a)
    on_valid = np.isin(fields.extra["face_id"], established)
    bad = on_valid & ~(fields.valid & np.isfinite(fields.K) & np.isfinite(fields.H))
    drawn = {}
    for cmd, mode in (("HullProd_ShowDevelopability", "developability"), ("HullProd_ShowPlates", "plates")):
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(a)
        FreeCADGui.runCommand(cmd)
        process(100)
        rgb = a.ViewObject.Proxy.coin_colors()
        mauve = np.all(np.isclose(rgb, colormaps.INVALID_RGB, atol=1e-3), axis=1)
        drawn[mode] = dict(colour_check(a), mauve_on_valid=int(np.sum(mauve[:len(on_valid)] & on_valid)),
                           png=shot("forebody_part5_%s" % mode))
    plates = [wording.face_value(f, "I_D") for f in doc["provenance"]["faces"]]
    above = [v for v in plates if v is not None and v > a.Kf]
    from hullprod_wb.gui.validity_panel import show_validity_panel
    panel = show_validity_panel(a)
    process(300)
    w = panel.areas_label  # scrolled to, as a person scrolls the task view to read it
    while w is not None and not isinstance(w, QtWidgets.QScrollArea):
        w = w.parentWidget()
    if w is not None:
        w.ensureWidgetVisible(panel.areas_label)
        process(200)
    seen, evidence_line = seen_by_a_person(panel.areas_label), panel.areas_label.text()
    png_panel = window_shot("forebody_part5_validity", panel.form)
    FreeCADGui.Control.closeDialog()
    return {"evidence_seen": seen, "png_validity": png_panel,"faces": len(doc["provenance"]["faces"]), "established": len(established),
            "samples_on_valid": int(on_valid.sum()), "bad_samples_on_valid": int(bad.sum()), "drawn": drawn,
            "k_f": a.Kf, "smallest_above_k_f": min(above) if above else None,
            "at_or_below_k_f": sum(1 for v in plates if v is not None and v <= a.Kf),
            "evidence_line": evidence_line, "unit": length_unit_label(a),
            "denominator": doc["validity"]["I_D"]["evidence"]["denominator"],
            "represented_area": doc["integrals"]["represented_area"]}


@step("preferences")
def _():
    from hullprod_wb.app import preferences
    from hullprod_wb.gui.preferences import PreferencesPage
    page = PreferencesPage()
    page.edits["DefaultHf"].setText("0.0002")
    page.saveSettings()
    stored = preferences.get("DefaultHf")
    preferences.reset()
    page.loadSettings()
    return {"stored": stored, "reloaded": page.edits["DefaultHf"].text()}


@step("gui_selftest")
def _():
    """The Test workbench's TestHullProdGui suite (hullprod_wb.gui.selftest) in this session."""
    active = FreeCAD.ActiveDocument.Name if FreeCAD.ActiveDocument else None
    out = selftest.run_suite("TestHullProdGui")
    if active in FreeCAD.listDocuments():
        FreeCAD.setActiveDocument(active)
    return out



def analysed_mesh(docname, label, lref=1.0, offset=(0.0, 0.0, 0.0)):
    """A new document holding a half-Wigley mesh (moved by offset) and its analysis (a fast run)."""
    from hullprod_wb.app import make_analysis
    from hullprod_wb.examples.analytic_meshes import half_wigley_mesh
    doc = FreeCAD.newDocument(docname)
    V, F = half_wigley_mesh(32, 8)
    V = V + np.asarray(offset, dtype=float)
    m = doc.addObject("Mesh::Feature", label)
    m.Mesh = Mesh.Mesh(V[F].tolist())
    doc.recompute()
    return doc, make_analysis(m, lref=lref, label=label + "_analysis")


def gl_viewport():
    """The widget of the active 3D view that receives the mouse (Coin's GL viewport)."""
    sub = FreeCADGui.getMainWindow().findChild(QtWidgets.QMdiArea).activeSubWindow().widget()
    gl = [w for w in sub.findChildren(QtWidgets.QWidget) if "GL" in w.metaObject().className() and w.isVisible()]
    return max(gl, key=lambda w: w.width() * w.height()) if gl else sub


def viewer_widgets():
    """The active 3D view's widgets that may take a person's mouse: its GL viewport, then the
    viewer widgets around it, largest first."""
    sub = FreeCADGui.getMainWindow().findChild(QtWidgets.QMdiArea).activeSubWindow().widget()
    found = [gl_viewport()]
    for w in sorted(sub.findChildren(QtWidgets.QWidget), key=lambda w: -w.width() * w.height()):
        if w.isVisible() and w not in found and "Viewer" in w.metaObject().className():
            found.append(w)
    return found


def fit_when_settled(tries=40):
    """Fit the active view once its GL viewport has kept one size for two looks of the event
    loop: a new document's view (and a panel opening beside it) is laid out some events
    later, and a fit before that may leave the hull outside the final viewport. Returns the
    viewport's (width, height)."""
    size = None
    for _ in range(tries):
        now = (gl_viewport().width(), gl_viewport().height())
        if now == size:
            break
        size = now
        process(50)
    view().fitAll()
    process(50)
    return [gl_viewport().width(), gl_viewport().height()]


def click(widget, x, y):
    """A left click of a person at widget pixel (x, y): move, press, release."""
    pos = QtCore.QPointF(x, y)
    glob = QtCore.QPointF(widget.mapToGlobal(QtCore.QPoint(int(x), int(y))))
    for kind, buttons in ((QtCore.QEvent.MouseMove, QtCore.Qt.NoButton),
                          (QtCore.QEvent.MouseButtonPress, QtCore.Qt.LeftButton),
                          (QtCore.QEvent.MouseButtonRelease, QtCore.Qt.NoButton)):
        button = QtCore.Qt.NoButton if kind == QtCore.QEvent.MouseMove else QtCore.Qt.LeftButton
        ev = QtGui.QMouseEvent(kind, pos, glob, button, buttons, QtCore.Qt.NoModifier)
        QtWidgets.QApplication.sendEvent(widget, ev)
        process(60)


@step("probe_click_selects_nothing")
def _():
    """A mouse click on the hull in probe mode probes it: the hull is not selected (its map
    stays), and no floating-point warning reaches the Report view."""
    import warnings
    from hullprod_wb.gui import probe
    doc, a = analysed_mesh("ProbeClick", "ClickHull")
    FreeCADGui.ActiveDocument = FreeCADGui.getDocument(doc.Name)
    hull_camera()
    a.ViewObject.ColorMap = "Developability"
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(a)
    FreeCADGui.runCommand("HullProd_Probe")
    process(100)
    panel = probe.ACTIVE
    viewport = fit_when_settled()
    bb = a.Source.Mesh.BoundBox
    centre = FreeCAD.Vector(bb.Center.x, bb.YMax, bb.Center.z)
    x, y = view().getPointOnScreen(centre)
    tried, hits = [], []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        # the widget that takes the mouse differs between versions: the GL viewport (0.20,
        # 1.0) or the viewer around it (1.1); each gets the click until one probes
        for vp in viewer_widgets():
            for px, py in ((x, vp.height() - y), (x, y)):
                tried.append([vp.metaObject().className(), px, py])
                click(vp, px, py)
                if panel.table.rowCount():
                    break
            if panel.table.rowCount():
                break
    selected = [o.Name for o in FreeCADGui.Selection.getSelection(doc.Name)]
    rows = panel.table.rowCount()
    FreeCADGui.Control.closeDialog()
    process(50)
    selectable_after = True
    FreeCADGui.Selection.addSelection(a)
    selectable_after = [o.Name for o in FreeCADGui.Selection.getSelection(doc.Name)] == [a.Name]
    FreeCADGui.Selection.clearSelection()
    FreeCAD.closeDocument(doc.Name)
    return {"rows": rows, "selected": selected, "tried": tried, "viewport": viewport,
            "target_on_screen": 0 <= x < viewport[0] and 0 <= y < viewport[1], "freecad": [int(v) for v in FreeCAD.Version()[:2]],
            "warnings": ["%s:%s: %s" % (w.filename, w.lineno, w.message) for w in caught],
            "selectable_after_close": selectable_after}


@step("fit_all_frames_a_hull_far_from_the_origin")
def _():
    """A hull in ship coordinates, far from the origin, its source hidden: the analysis's
    bounding box is the hull's, and after Std_ViewFitAll (what V, F runs) the hull fills
    the view instead of sitting small beside the origin."""
    from pivy import coin
    doc, a = analysed_mesh("FarHull", "FarHull", offset=(200.0, 40.0, 10.0))
    FreeCADGui.ActiveDocument = FreeCADGui.getDocument(doc.Name)
    a.Source.ViewObject.Visibility = False
    a.ViewObject.Visibility = True
    a.ViewObject.ShowLegend = True
    process(100)
    v = view()
    act = coin.SoGetBoundingBoxAction(v.getViewer().getSoRenderManager().getViewportRegion())
    act.apply(a.ViewObject.RootNode)
    box = act.getBoundingBox()  # the action's own box: read while the action lives
    lo, hi = [float(x) for x in box.getMin().getValue()], [float(x) for x in box.getMax().getValue()]
    bb = a.Source.Mesh.BoundBox
    v.viewIsometric()
    FreeCADGui.runCommand("Std_ViewFitAll")
    process(100)
    corners = [FreeCAD.Vector(x, y, z) for x in (bb.XMin, bb.XMax) for y in (bb.YMin, bb.YMax) for z in (bb.ZMin, bb.ZMax)]
    screen = np.array([v.getPointOnScreen(c) for c in corners], dtype=float)
    w, h = v.getSize()
    out = {"bbox": [lo, hi], "hull": [[bb.XMin, bb.YMin, bb.ZMin], [bb.XMax, bb.YMax, bb.ZMax]],
           "extent": [float(np.ptp(screen[:, 0])) / w, float(np.ptp(screen[:, 1])) / h], "png": shot("far_hull_fit")}
    FreeCAD.closeDocument(doc.Name)
    return out


@step("legend_follows_remaining_analysis")
def _():
    """Three analyses, the newest two deleted from the tree: the colour bar goes to the one
    still coloured."""
    doc, first = analysed_mesh("LegendAfterDelete", "Hull1")
    src = first.Source
    from hullprod_wb.app import make_analysis
    more = [make_analysis(src, lref=1.0, label="Hull1_analysis_%d" % k) for k in (2, 3)]
    from hullprod_wb.gui.legend import legend_to
    for a in [first] + more:
        a.ViewObject.Visibility = True
    legend_to(more[-1:])
    before = [o.Label for o in (first, *more) if o.ViewObject.ShowLegend]
    for a in reversed(more):
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(a)
        FreeCADGui.runCommand("Std_Delete")
        process(50)
    left = [o for o in doc.Objects if o.Name == first.Name]
    out = {"before": before, "left": [o.Label for o in left],
           "visible": bool(first.ViewObject.Visibility), "legend": bool(first.ViewObject.ShowLegend),
           "legend_nodes": first.ViewObject.Proxy.legend_switch.getNumChildren(),
           "legend_switch": first.ViewObject.Proxy.legend_switch.whichChild.getValue()}
    FreeCAD.closeDocument(doc.Name)
    return out


class LoopClock:
    """The longest interval between the ticks of a 20 ms Qt timer while it runs: how long
    the event loop was kept from running."""

    def __init__(self):
        self.longest, self.last = 0.0, None
        self.timer = QtCore.QTimer()
        self.timer.setInterval(20)
        self.timer.timeout.connect(self.tick)

    def tick(self):
        now = time.perf_counter()
        self.longest = max(self.longest, now - self.last)
        self.last = now

    def start(self):
        self.last = time.perf_counter()
        self.timer.start()

    def stop(self):
        self.tick()
        self.timer.stop()


@step("study_in_process")
def _():
    """The threshold study of an Analyze analysis of a shared hull (KCS, 125 faces, the
    document saved): the command returns at once, the event loop keeps running (longest
    gap of a 20 ms timer), progress arrives, the 1e-4 row has Analyze's I_D and statuses,
    the report is beside the document, titled after the hull; then a second study is
    cancelled with the dialog's button after its first progress."""
    from hullprod_wb.gui import analyze_panel, dialogs, verification_commands
    src = open_hull("kcs_full_closed_ohp.iges", "kcsstudy")
    if src is None:
        return {"skipped": "public hulls not present"}
    doc = src.Document
    folder = os.path.join(WORK, "study_document")
    os.makedirs(folder, exist_ok=True)
    doc.saveAs(os.path.join(folder, "kcs_study.FCStd"))
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(src)
    FreeCADGui.runCommand("HullProd_Analyze")
    made = analyze_panel.LAST_PANEL.run()
    FreeCADGui.Control.closeDialog()
    a = made[0]
    metrics = ("I_D", "I_D_plus", "I_D_minus", "a_flat", "a_single", "a_elliptic", "a_saddle")
    out = {"analysis": {m: getattr(a, m) for m in metrics},
           "analysis_status": {m: getattr(a, m + "_Status") for m in metrics}, "lref": a.LrefUsed,
           "expected_report": os.path.join(folder, "kcsstudy_thresholds_study.html")}
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(a)
    clock = LoopClock()
    clock.start()
    t = time.perf_counter()
    FreeCADGui.runCommand("HullProd_StudyThresholds")
    out["command_returned_after"] = time.perf_counter() - t
    run = verification_commands.LAST_RUN
    wait_for(lambda: run.finished, 600)
    clock.stop()
    out.update(study_seconds=time.perf_counter() - t, longest_event_loop_gap=clock.longest,
               progress_events=run.events, report=run.report, error=run.error)
    if run.report:
        out["rows"] = {"%g" % r["h_f"]: {"I_D": r["I_D"], "I_D_plus": r["I_D_plus"], "I_D_minus": r["I_D_minus"],
                                        "status": r["status"]} for r in run.study["rows"]}
        out["study_lref"] = run.study["lref"]
        out["report_title"] = open(run.report).read().split("<h1>", 1)[1].split("</h1>", 1)[0]
    n_info = len(dialogs.LOG)
    FreeCADGui.runCommand("HullProd_StudyThresholds")
    second = verification_commands.LAST_RUN
    wait_for(lambda: second.events > 0 or second.finished, 120)
    out["cancel_pressed_while_running"] = not second.finished
    t = time.perf_counter()
    second.dialog.findChild(QtWidgets.QPushButton).click()
    wait_for(lambda: second.finished and second.proc.proc.poll() is not None, 5)
    out.update(cancel_seconds=time.perf_counter() - t, cancelled_state=second.proc.state,
               cancelled_report=second.report, cancel_messages=[list(m) for m in dialogs.LOG[n_info:]])
    FreeCAD.closeDocument(doc.Name)
    return out


@step("compare_across_documents")
def _():
    """Two hulls opened each in its own document: Compare lists the analyses of both."""
    from hullprod_wb.gui import compare_panel, dialogs
    d1, a1 = analysed_mesh("CompareDocA", "HullA", lref=1.0)
    d2, a2 = analysed_mesh("CompareDocB", "HullB", lref=1.1)
    FreeCAD.setActiveDocument(d2.Name)
    FreeCADGui.ActiveDocument = FreeCADGui.getDocument(d2.Name)
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(a2)  # one analysis selected, in the active document
    n_err = len([m for m in dialogs.LOG if m[0] == "error"])
    FreeCADGui.runCommand("HullProd_Compare")
    process(100)
    p = compare_panel.LAST_PANEL
    errors = [m[2] for m in dialogs.LOG if m[0] == "error"][n_err:]
    listed = [p.choice.item(i).text() for i in range(p.choice.count())] if p else []
    every_open = ["%s: %s" % (d.Label, o.Label) for d in FreeCAD.listDocuments().values() for o in d.Objects
                  if o.TypeId == a1.TypeId and hasattr(o, "I_D")]
    compared = p.cmp["labels"] if p and p.cmp else []
    columns = p.table.columnCount() if p and p.table is not None else 0
    # one left ticked: a note and no table; all ticked again
    for i in range(1, p.choice.count()):
        p.choice.item(i).setCheckState(QtCore.Qt.Unchecked)
    process(20)
    note = p.flags_label.text()
    for i in range(1, p.choice.count()):
        p.choice.item(i).setCheckState(QtCore.Qt.Checked)
    process(20)
    retabled = p.table.columnCount() if p.table is not None else 0
    window_shot("compare_documents")
    documents = [d1.Label, d2.Label]
    FreeCADGui.Control.closeDialog()
    for d in (d1, d2):
        FreeCAD.closeDocument(d.Name)
    return {"errors": errors, "listed": listed, "compared": compared, "documents": documents, "every_open": every_open, "columns": columns,
            "flags": p.cmp["flags"] if p.cmp else [], "note_one_ticked": note, "retabled": retabled}


def shown_texts(root):
    """Every text a person can read in a widget tree: labels, buttons, titles, tool tips,
    table and tree cells and headers, list rows, combo box entries."""
    out = []
    for w in [root] + root.findChildren(QtWidgets.QWidget):
        out += [w.toolTip()]
        for attr in ("text", "title", "placeholderText"):
            f = getattr(w, attr, None)
            if callable(f) and not isinstance(w, QtWidgets.QAbstractItemView):
                try:
                    v = f()
                except TypeError:
                    continue
                if isinstance(v, str):
                    out.append(v)
        if isinstance(w, QtWidgets.QComboBox):
            out += [w.itemText(i) for i in range(w.count())]
        if isinstance(w, QtWidgets.QTableWidget):
            out += [w.item(i, j).text() for i in range(w.rowCount()) for j in range(w.columnCount()) if w.item(i, j)]
            out += [w.item(i, j).toolTip() for i in range(w.rowCount()) for j in range(w.columnCount()) if w.item(i, j)]
            out += [w.horizontalHeaderItem(j).text() for j in range(w.columnCount()) if w.horizontalHeaderItem(j)]
            out += [w.verticalHeaderItem(i).text() for i in range(w.rowCount()) if w.verticalHeaderItem(i)]
        if isinstance(w, QtWidgets.QTreeWidget):
            it = QtWidgets.QTreeWidgetItemIterator(w)
            while it.value():
                out += [it.value().text(c) for c in range(w.columnCount())]
                it += 1
        if isinstance(w, QtWidgets.QListWidget):
            out += [w.item(i).text() for i in range(w.count())]
    return [t for t in out if t]


def scroll_area_of(panel):
    """The scroll area holding panel (the task view), or None."""
    w = panel.parentWidget()
    while w is not None and not isinstance(w, QtWidgets.QScrollArea):
        w = w.parentWidget()
    return w


def widget_name(c):
    """A shown widget's object name, else the start of its text or title."""
    return c.objectName() or getattr(c, "text", getattr(c, "title", str))()[:40]


def clipped_widgets(panel):
    """Shown widgets of panel whose right edge lies beyond the visible width of the scroll
    area holding the panel (the task view), when that area shows no horizontal scroll bar."""
    area = scroll_area_of(panel)
    if area is None or area.horizontalScrollBar().isVisible():
        return []
    vp = area.viewport()
    right = vp.mapToGlobal(QtCore.QPoint(vp.width(), 0)).x()
    return ["%s(%s) %d > %d" % (type(c).__name__, widget_name(c),
                                c.mapToGlobal(QtCore.QPoint(c.width(), 0)).x(), right)
            for c in panel.findChildren(QtWidgets.QWidget) if c.isVisible()
            and c.mapToGlobal(QtCore.QPoint(c.width(), 0)).x() > right + 1] + clipped_titles(panel)


def clipped_titles(panel):
    """Shown group boxes whose title (with its check box) is wider than the box: Qt cuts
    the title's end off without a sign."""
    out = []
    for box in panel.findChildren(QtWidgets.QGroupBox):
        if not box.isVisible() or not box.title():
            continue
        opt = QtWidgets.QStyleOptionGroupBox()
        box.initStyleOption(opt)
        label = box.style().subControlRect(QtWidgets.QStyle.CC_GroupBox, opt, QtWidgets.QStyle.SC_GroupBoxLabel, box)
        need = label.x() + label.width()
        if need > box.width():
            out.append("QGroupBox title(%s) %d > %d" % (box.title()[:40], need, box.width()))
    return out


def scrolls_sideways(panel):
    """Whether the scroll area holding panel (the task view) shows a horizontal scroll bar;
    if it does, the shown widgets whose smallest width exceeds the area's visible width."""
    w = scroll_area_of(panel)
    if w is None or not w.horizontalScrollBar().isVisible():
        return False
    width = w.viewport().width()
    wide = [c for c in panel.findChildren(QtWidgets.QWidget) if c.isVisible() and c.minimumSizeHint().width() > width]
    return ["%s(%s) %d > %d" % (type(c).__name__, widget_name(c), c.minimumSizeHint().width(), width)
            for c in wide if not any(o is not c and c.isAncestorOf(o) for o in wide)] or ancestors_widths(panel, w)


def ancestors_widths(panel, area):
    """'class min/width' of panel and its parents up to the scroll area (what needs the width)."""
    out, c = [], panel
    while c is not None and c is not area:
        out.append("%s %d/%d" % (type(c).__name__, c.minimumSizeHint().width(), c.width()))
        c = c.parentWidget()
    kids = sorted((c for c in panel.findChildren(QtWidgets.QWidget) if c.isVisible()),
                  key=lambda c: -c.minimumSizeHint().width())[:4]
    return out + ["widest: %s(%s) %d" % (type(c).__name__, widget_name(c), c.minimumSizeHint().width()) for c in kids]


@step("panels_fit_and_speak_plainly")
def _():
    """The Analyze, validity, probe and compare panels at 1280x720 and 1600x1000 with the
    combo view at FreeCAD's default width: no widget is cut off on the right without a
    scroll bar, the validity table's reason column is wide enough to read, and no text
    shown (nor any property description of the analysis) carries a label of the paper."""
    from hullprod_wb.gui import analyze_panel, validity_panel, probe, compare_panel
    from hullprod_wb.gui.wording import PAPER_LABEL
    from hullprod_wb.app import make_analysis
    doc, a = analysed_mesh("PanelsFit", "FitHull")
    b = make_analysis(a.Source, lref=1.2, label="FitHull_analysis_2")
    FreeCADGui.ActiveDocument = FreeCADGui.getDocument(doc.Name)
    mw = FreeCADGui.getMainWindow()
    combo = [d for d in mw.findChildren(QtWidgets.QDockWidget) if d.objectName() in ("Combo View", "ComboView")]
    out, texts = {}, []
    # a second analysis made by a macro takes the colour bar; the first one's is turned off
    out["legends_on"] = [o.Label for o in (a, b) if o.ViewObject.ShowLegend]
    for w, h in ((1280, 720), (1600, 1000)):
        mw.showNormal()
        mw.resize(w, h)
        if combo:  # FreeCAD's default: the dock at its own size hint
            mw.resizeDocks(combo, [combo[0].sizeHint().width()], QtCore.Qt.Horizontal)
        process(200)
        rec = {"combo_width": combo[0].width() if combo else None}
        a.Source.ViewObject.Visibility = True  # a hidden object cannot be selected
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(a.Source)
        before = analyze_panel.LAST_PANEL
        FreeCADGui.runCommand("HullProd_Analyze")
        process(200)
        p = analyze_panel.LAST_PANEL
        assert p is not before, "Analyze opened no panel"
        p.advanced.setChecked(True)
        process(100)
        rec["analyze"] = clipped_widgets(p.form)
        rec["analyze_scrolls_sideways"] = scrolls_sideways(p.form)
        texts += shown_texts(p.form)
        window_shot("panel_fit_analyze_%dx%d" % (w, h), p.form)
        FreeCADGui.Control.closeDialog()
        vpanel = validity_panel.show_validity_panel(a)
        process(200)
        rec["validity"] = clipped_widgets(vpanel.form)
        rec["validity_scrolls_sideways"] = scrolls_sideways(vpanel.form)
        t = vpanel.signature_table
        rec["reason_chars"] = t.viewport().width() // max(1, t.fontMetrics().averageCharWidth())
        vpanel.detail_button.setChecked(True)
        process(50)
        texts += shown_texts(vpanel.form)
        window_shot("panel_fit_validity_%dx%d" % (w, h), vpanel.form)
        FreeCADGui.Control.closeDialog()
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(a)
        FreeCADGui.runCommand("HullProd_Probe")
        process(100)
        pp = probe.ACTIVE
        from hullprod_wb.app import analysis_fields
        f = analysis_fields(a)
        pp.probe(a, f.points[f.triangles[len(f.triangles) // 2]].mean(axis=0))
        process(50)
        rec["probe"] = clipped_widgets(pp.form)
        texts += shown_texts(pp.form)
        FreeCADGui.Control.closeDialog()
        cp = compare_panel.show_compare_panel([a, b])
        process(100)
        rec["compare"] = clipped_widgets(cp.form)
        texts += shown_texts(cp.form)
        FreeCADGui.Control.closeDialog()
        out["%dx%d" % (w, h)] = rec
    texts += [a.getDocumentationOfProperty(n) for n in a.PropertiesList]
    texts += [a.ViewObject.getDocumentationOfProperty(n) for n in a.ViewObject.PropertiesList]
    out["labels_seen"] = sorted({t[:120] for t in texts if PAPER_LABEL.search(t)})
    out["texts_checked"] = len(texts)
    mw.resize(1500, 950)
    if combo:
        mw.resizeDocks(combo, [560], QtCore.Qt.Horizontal)
    process(100)
    FreeCAD.closeDocument(doc.Name)
    return out


def bezier_patches(bump=0.0, n=3):
    """The compound of analytic_shapes.patch_grid, the middle patch's pole moved up by bump."""
    import Part
    from hullprod_wb.examples.analytic_shapes import patch_grid
    return Part.Compound(patch_grid([(n * n // 2, bump)], n))


def loop_clock(ms=20):
    """A started Qt timer that records the time of each of its ticks, and that list: the gaps
    between ticks are how long the event loop was held (longest_gap)."""
    ticks = []
    clock = QtCore.QTimer()
    clock.setInterval(ms)
    clock.timeout.connect(lambda: ticks.append(time.perf_counter()))
    clock.start()
    return clock, ticks


def longest_gap(ticks):
    gaps = [b - a for a, b in zip(ticks, ticks[1:])]
    return max(gaps) if gaps else None


@step("live_update")
def _():
    """AutoUpdate on: an edit of the source (its shape replaced by one with a pole moved)
    and a recompute start a background update; the event loop keeps ticking; the result
    lands in place with the change of I_D and the faces integrated again. AutoUpdate off: the
    recompute only marks the results out of date."""
    from hullprod_wb.gui import live_update
    from hullprod_wb.gui.validity_panel import change_line
    os.environ["HULLPROD_FACE_CACHE"] = os.path.join(WORK, "face_store")  # this check's own store
    doc = FreeCAD.newDocument("LiveUpdate")
    src = doc.addObject("Part::Feature", "Patches")
    src.Shape = bezier_patches()
    doc.recompute()
    a = hullprod_wb.make_analysis(src, lref=4.0)
    out = {"first_status": a.Status, "first_I_D": a.I_D, "first_delta": a.DeltaI_D}
    a.AutoUpdate = True
    t = time.perf_counter()
    doc.recompute()
    out["toggle_recompute_s"] = time.perf_counter() - t
    out["after_toggle"] = {"status": a.Status, "I_D": a.I_D, "running": a.Name in live_update.RUNNING}
    src.Shape = bezier_patches(0.05)
    clock, ticks = loop_clock()
    t = time.perf_counter()
    doc.recompute()
    out["edit_recompute_s"] = time.perf_counter() - t
    out["status_after_edit"] = a.Status
    out["running"] = a.Name in live_update.RUNNING
    statuses = set()
    done = wait_for(lambda: statuses.add(a.Status.split(":")[0]) or a.Status == "ok", 120)
    out["update_s"] = time.perf_counter() - t
    clock.stop()
    out.update(done=done, statuses=sorted(statuses), max_gap=longest_gap(ticks), ticks=len(ticks),
               I_D=a.I_D, delta=a.DeltaI_D, integrated=list(a.FacesIntegrated), out_of_date=a.OutOfDate,
               cache=json.loads(a.ResultJSON)["provenance"]["cache"], change_line=change_line(a))
    a.ViewObject.Visibility = True
    src.ViewObject.Visibility = False  # the map alone (the source's own tessellation would show through)
    view().viewIsometric()
    view().fitAll()
    from hullprod_wb.gui.validity_panel import show_validity_panel
    show_validity_panel(a)
    process(300)
    out["png"] = screen_shot("live_update")
    FreeCADGui.Control.closeDialog()
    from hullprod_wb.app.analysis import analysis_fields
    a.ViewObject.ColorMap = "Change"
    process(200)
    rgb = np.asarray(a.ViewObject.Proxy.colors, float)
    fid = np.asarray(analysis_fields(a).extra["face_id"])
    white = np.array([0.97, 0.97, 0.97])
    out["change_map"] = {int(f): float(np.abs(rgb[fid == f] - white).max()) for f in np.unique(fid)}
    out["change_legend"] = a.ViewObject.Proxy.legend.title
    out["png_change"] = screen_shot("live_update_change")
    a.ViewObject.ColorMap = "Developability"
    a.AutoUpdate = False
    doc.recompute()
    src.Shape = bezier_patches(0.1)
    t = time.perf_counter()
    doc.recompute()
    out["off"] = {"recompute_s": time.perf_counter() - t, "status": a.Status, "I_D": a.I_D,
                  "out_of_date": a.OutOfDate, "running": a.Name in live_update.RUNNING}
    src.Shape = bezier_patches(0.05)  # back as it was: the results are current again
    doc.recompute()
    out["back"] = {"status": a.Status, "out_of_date": a.OutOfDate}
    a.AutoUpdate = True
    doc.recompute()
    import Part
    src.Shape = Part.Compound([])  # nothing left to assess: said, the results kept
    doc.recompute()
    out["emptied"] = {"status": a.Status, "I_D": a.I_D, "running": a.Name in live_update.RUNNING}

    os.environ["HULLPROD_FACE_CACHE"] = "off"
    FreeCAD.closeDocument(doc.Name)
    return out


@step("live_update_hull")
def _():
    """bench/gui_live_update.py: HULLPROD_LIVE_UPDATE_FILES = [base, variant] (BRep files that
    differ in one face): the base analysed, AutoUpdate on, the source's shape replaced by the
    variant's, recompute; the seconds from the edit to the updated map and the longest gap of
    the event loop meanwhile."""
    files = json.loads(os.environ.get("HULLPROD_LIVE_UPDATE_FILES") or "null")
    if not files:
        return {"skipped": "no files (bench/gui_live_update.py gives them)"}
    import Part
    from hullprod_wb.gui import live_update
    doc = FreeCAD.newDocument("LiveUpdateHull")
    src = doc.addObject("Part::Feature", "Hull")
    src.Shape = Part.read(files[0])
    doc.recompute()
    t = time.perf_counter()
    a = hullprod_wb.make_analysis(src)
    out = {"first_s": time.perf_counter() - t, "first_status": a.Status, "first_I_D": a.I_D}
    a.AutoUpdate = True
    doc.recompute()
    variant = Part.read(files[1])
    clock, ticks = loop_clock()
    t = time.perf_counter()
    src.Shape = variant
    doc.recompute()
    out["edit_recompute_s"] = time.perf_counter() - t
    out["running"] = a.Name in live_update.RUNNING
    done = wait_for(lambda: a.Status == "ok", 600)
    process(100)  # the map drawn
    out["edit_to_map_s"] = time.perf_counter() - t
    clock.stop()
    cache = json.loads(a.ResultJSON)["provenance"].get("cache") or {}
    out.update(done=done, status=a.Status, max_gap=longest_gap(ticks), I_D=a.I_D, delta=a.DeltaI_D,
               integrated=list(a.FacesIntegrated), hits=cache.get("hits"), misses=cache.get("misses"))
    FreeCAD.closeDocument(doc.Name)
    return out

finish()
