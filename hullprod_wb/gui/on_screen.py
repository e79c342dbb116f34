"""Whether a widget is on screen for a person to see, and bringing a task panel into view.

Qt's isVisible alone says a widget is shown, not that it can be seen: it may sit in a
window part clipped away, or under another widget (FreeCAD 1.x draws its docks in overlays
over the 3D view). seen_by_a_person asks the window system's own hit test
(QApplication.widgetAt) at points inside the widget as well.
"""
from .qt import QtCore, QtWidgets

__all__ = ["seen_by_a_person", "bring_into_view", "show_task_panel", "describe", "visible_rect",
           "scroll_sideways_when_narrow"]


def describe(widget):
    """'Class(objectName)' of a widget, or None."""
    if widget is None:
        return None
    return "%s(%s)" % (type(widget).__name__, widget.objectName())


def _hidden_ancestor(widget):
    """Why widget is not shown, or None: the first of it and its ancestors that is hidden,
    or that is a page of a stack (tab widget) other than the current one."""
    child, w = None, widget
    while w is not None:
        if w.isHidden():
            return "%s is hidden" % describe(w)
        if child is not None and isinstance(w, QtWidgets.QStackedWidget) and w.currentWidget() is not child:
            return "%s is not the current page of %s" % (describe(child), describe(w))
        child, w = w, w.parentWidget()
    return None


def _global_rect(widget):
    return QtCore.QRect(widget.mapToGlobal(QtCore.QPoint(0, 0)), widget.size())


def visible_rect(widget):
    """The part of widget inside all its ancestors (QRect, global coordinates)."""
    rect = _global_rect(widget)
    w = widget.parentWidget()
    while w is not None and not rect.isEmpty():
        rect = rect.intersected(_global_rect(w))
        w = w.parentWidget()
    return rect


def _probe_points(rect):
    """Centre and four points just inside the corners of rect (global)."""
    dx, dy = max(2, rect.width() // 10), max(2, rect.height() // 10)
    l, t, r, b = rect.left() + dx, rect.top() + dy, rect.right() - dx, rect.bottom() - dy
    return [rect.center(), QtCore.QPoint(l, t), QtCore.QPoint(r, t), QtCore.QPoint(l, b), QtCore.QPoint(r, b)]


def seen_by_a_person(widget, other_windows_ok=False):
    """Record (dict) of whether widget can be seen on screen: 'seen' is True when it is
    shown (with its ancestors, on the current tab page), of non-zero size, not fully
    clipped, and at its centre and near its corners the window system finds it (or one of
    its children) on top. The other keys say which of these failed ('why').
    other_windows_ok: a point under another top-level window (a dialog the person can move
    away, such as the Test workbench's runner) counts as seen; it is listed in 'under'."""
    rec = {"seen": False, "widget": describe(widget), "size": [widget.width(), widget.height()],
           "shown": widget.isVisible(), "hidden": _hidden_ancestor(widget), "points": [], "covered_by": []}
    if widget.window() is not None and widget.window().isMinimized():
        rec["hidden"] = rec["hidden"] or "its window is minimised"
    clip = visible_rect(widget)
    rec["clipped_to"] = [clip.x(), clip.y(), clip.width(), clip.height()]
    rec["region_empty"] = bool(widget.visibleRegion().isEmpty())
    if not rec["shown"] or rec["hidden"]:
        rec["why"] = rec["hidden"] or "not visible"
        return rec
    if widget.width() <= 0 or widget.height() <= 0:
        rec["why"] = "zero size"
        return rec
    if clip.isEmpty():
        rec["why"] = "clipped away by its parents"
        return rec
    if rec["region_empty"]:
        rec["why"] = "no visible region (covered by opaque widgets)"
        return rec
    rec["under"] = []
    for p in _probe_points(clip):
        top = QtWidgets.QApplication.widgetAt(p)
        hit = top is not None and (top is widget or widget.isAncestorOf(top))
        if not hit and other_windows_ok and top is not None and top.window() is not widget.window():
            rec["under"].append(describe(top.window()))
            hit = True
        rec["points"].append([p.x(), p.y(), hit])
        if not hit:
            rec["covered_by"].append(describe(top) or "nothing (off the screen)")
    rec["seen"] = all(h for _, _, h in rec["points"])
    if not rec["seen"]:
        rec["why"] = "covered at %d of %d points by %s" % (len(rec["covered_by"]), len(rec["points"]),
                                                          sorted(set(rec["covered_by"])))
    return rec


def bring_into_view(widget):
    """Make the tab pages and docks holding widget the current ones and raise them (the
    task view behind the Model tab of FreeCAD's combo view, a tabified or overlaid dock).
    Presentation only: nothing of the document changes."""
    child, w = None, widget
    while w is not None:
        if child is not None and isinstance(w, QtWidgets.QStackedWidget) and w.currentWidget() is not child:
            tabs = w.parentWidget()
            if isinstance(tabs, QtWidgets.QTabWidget):
                tabs.setCurrentWidget(child)
            else:
                w.setCurrentWidget(child)
        if isinstance(w, QtWidgets.QDockWidget):
            w.raise_()  # a tabified dock: its tab becomes the current one
            if w.isHidden():  # closed by the user
                w.show()
        child, w = w, w.parentWidget()


def show_task_panel(panel):
    """Show panel in FreeCAD's task view, closing another open task dialog first, and bring
    the task view forward (its tab or dock may be behind another)."""
    import FreeCADGui
    if FreeCADGui.Control.activeDialog():
        FreeCADGui.Control.closeDialog()
    FreeCADGui.Control.showDialog(panel)
    for form in panel.form if isinstance(panel.form, (list, tuple)) else [panel.form]:
        bring_into_view(form)
        scroll_sideways_when_narrow(form)
    return panel


def scroll_sideways_when_narrow(widget):
    """Let the scroll area holding widget (the task view) scroll sideways when the widget
    needs more width than it shows: a narrow combo view otherwise cuts the right side off."""
    w = widget.parentWidget()
    while w is not None and not isinstance(w, QtWidgets.QScrollArea):
        w = w.parentWidget()
    if w is not None:
        w.setHorizontalScrollBarPolicy(QtCore.Qt.ScrollBarAsNeeded)
    return w
