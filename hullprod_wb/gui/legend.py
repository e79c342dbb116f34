"""Colour bars and legends: a Coin overlay fixed to the 3D view, and a Qt widget.

Both draw a colormaps.Legend; neither computes anything.
"""
import numpy as np

from . import colormaps

#: The overlay lives in a tiny normalised box (side 2 * HUD_SCALE model units around the
#: origin) seen through its own orthographic camera, and out of the view's bounding box
#: (unbounded), so that "fit all" frames the hull alone.
HUD_SCALE = 1.0e-6
#: Overlay layout in normalised device coordinates ([-1, 1] across the view): at the left
#: edge, clear of the navigation cube (top right) and of the axis cross (bottom right).
BAR_X0, BAR_X1, BAR_Y0, BAR_Y1 = -0.955, -0.92, -0.60, 0.45


def _text(coin, x, y, lines, justification=None):
    sep = coin.SoSeparator()
    tr = coin.SoTranslation()
    tr.translation.setValue(x * HUD_SCALE, y * HUD_SCALE, 0.0)
    txt = coin.SoText2()
    txt.string.setValues(0, len(lines), [str(s) for s in lines])
    if justification is not None:
        txt.justification = justification
    sep.addChild(tr)
    sep.addChild(txt)
    return sep


def _quads(coin, corners, colors):
    """Quads (k, 4, 2) in NDC with per-vertex colours (k, 4, 3)."""
    k = len(corners)
    sep = coin.SoSeparator()
    mb = coin.SoMaterialBinding()
    mb.value = coin.SoMaterialBinding.PER_VERTEX_INDEXED
    mat = coin.SoMaterial()
    cols = np.asarray(colors, float).reshape(-1, 3)
    mat.diffuseColor.setValues(0, len(cols), cols.tolist())
    co = coin.SoCoordinate3()
    pts = np.column_stack([np.asarray(corners, float).reshape(-1, 2) * HUD_SCALE, np.zeros(4 * k)])
    co.point.setValues(0, len(pts), pts.tolist())
    fs = coin.SoIndexedFaceSet()
    idx = np.column_stack([np.arange(4 * k).reshape(k, 4), -np.ones(k, int)]).ravel().tolist()
    fs.coordIndex.setValues(0, len(idx), idx)
    fs.materialIndex.setValues(0, len(idx), idx)
    for node in (mb, mat, co, fs):
        sep.addChild(node)
    return sep


def unbounded(node):
    """node in a group that the view's bounding box leaves out (FreeCAD's
    SoSkipBoundingGroup, mode EXCLUDE_BBOX): the overlay's box sits at the origin, and a
    hull in ship coordinates may lie far from it, where "fit all" would frame both and show
    the hull small in a corner. A plain group where FreeCAD has no such node."""
    from pivy import coin
    kind = coin.SoType.fromName(coin.SbName("SoSkipBoundingGroup"))
    if kind.isBad():
        group = coin.SoGroup()
    else:
        group = kind.createInstance()
        group.getField(coin.SbName("mode")).set("EXCLUDE_BBOX")
    group.addChild(node)
    return group


def build_overlay(legend, font_size=13.0):
    """SoSeparator drawing legend at the right of the 3D view (screen-fixed, unpickable)."""
    from pivy import coin
    root = coin.SoAnnotation()
    ps = coin.SoPickStyle()
    ps.style = coin.SoPickStyle.UNPICKABLE
    cam = coin.SoOrthographicCamera()
    cam.viewportMapping = coin.SoCamera.LEAVE_ALONE
    cam.position.setValue(0.0, 0.0, 5.0 * HUD_SCALE)
    cam.height = 2.0 * HUD_SCALE
    cam.aspectRatio = 1.0
    cam.nearDistance = 1.0 * HUD_SCALE
    cam.farDistance = 10.0 * HUD_SCALE
    lm = coin.SoLightModel()
    lm.model = coin.SoLightModel.BASE_COLOR
    font = coin.SoFont()
    font.size = font_size
    for node in (ps, cam, lm, font):
        root.addChild(node)
    if legend.kind == "gradient":
        n = 32
        s = np.linspace(0.0, 1.0, n + 1)
        y = BAR_Y0 + s * (BAR_Y1 - BAR_Y0)
        corners = np.stack([np.column_stack([np.full(n, BAR_X0), y[:-1]]), np.column_stack([np.full(n, BAR_X1), y[:-1]]),
                            np.column_stack([np.full(n, BAR_X1), y[1:]]), np.column_stack([np.full(n, BAR_X0), y[1:]])], axis=1)
        c0, c1 = colormaps.ramp(s[:-1], legend.anchors), colormaps.ramp(s[1:], legend.anchors)
        root.addChild(_quads(coin, corners, np.stack([c0, c0, c1, c1], axis=1)))
        labels = coin.SoSeparator()
        labels.addChild(_base_color(coin, (0.05, 0.05, 0.05)))
        for pos, text in legend.ticks:
            labels.addChild(_text(coin, BAR_X1 + 0.012, BAR_Y0 + pos * (BAR_Y1 - BAR_Y0) - 0.012, [text]))
        root.addChild(labels)
        top = BAR_Y1 + 0.06
    else:
        k = len(legend.entries)
        h = 0.09
        ys = BAR_Y1 - h * np.arange(k)
        corners = np.stack([np.column_stack([np.full(k, BAR_X0), ys - 0.06]), np.column_stack([np.full(k, BAR_X1), ys - 0.06]),
                            np.column_stack([np.full(k, BAR_X1), ys]), np.column_stack([np.full(k, BAR_X0), ys])], axis=1)
        cols = np.repeat(np.array([rgb for rgb, _ in legend.entries], float)[:, None, :], 4, axis=1)
        root.addChild(_quads(coin, corners, cols))
        labels = coin.SoSeparator()
        labels.addChild(_base_color(coin, (0.05, 0.05, 0.05)))
        for y, (_, text) in zip(ys, legend.entries):
            labels.addChild(_text(coin, BAR_X1 + 0.012, y - 0.045, [text.split(" (")[0]]))
        root.addChild(labels)
        top = BAR_Y1 + 0.06
    head = coin.SoSeparator()
    head.addChild(_base_color(coin, (0.05, 0.05, 0.05)))
    lines = [legend.title]
    if len(legend.title) > 18 and " (" in legend.title:
        first, rest = legend.title.split(" (", 1)
        lines = [first, "(" + rest]
    head.addChild(_text(coin, BAR_X0, top + 0.06 * (len(lines) - 1), lines))
    root.addChild(head)
    return root


def _base_color(coin, rgb):
    bc = coin.SoBaseColor()
    bc.rgb.setValue(*rgb)
    return bc


def make_legend_widget(legend, parent=None):
    """A Qt widget painting legend (gradient bar with ticks, or coloured squares)."""
    from .qt import QtCore, QtGui, QtWidgets

    class LegendWidget(QtWidgets.QWidget):
        def __init__(self, legend, parent=None):
            super().__init__(parent)
            self.legend = legend
            self._fit()

        def _fit(self):
            """As tall as the title, the bar and ticks (or the entries) and the note wrapped to
            the present width."""
            fm = self.fontMetrics()
            line, lg = fm.height() + 2, self.legend
            above = line + 4 + (24 + line if lg.kind == "gradient" else line * ((len(lg.entries) + 1) // 2))
            note = fm.boundingRect(QtCore.QRect(0, 0, max(40, self.width() - 8), 10 ** 5), QtCore.Qt.TextWordWrap,
                                   lg.note).height() if lg.note else 0
            self.setMinimumHeight(above + note + 6)

        def resizeEvent(self, event):  # noqa: N802 - Qt API
            super().resizeEvent(event)
            self._fit()

        def set_legend(self, legend):
            self.legend = legend
            self._fit()
            self.update()

        def paintEvent(self, event):  # noqa: N802 - Qt API
            lg = self.legend
            p = QtGui.QPainter(self)
            w = self.width()
            fm = p.fontMetrics()
            line = fm.height() + 2
            p.drawText(4, fm.ascent() + 2, lg.title)
            y = line + 4
            if lg.kind == "gradient":
                grad = QtGui.QLinearGradient(10, 0, w - 10, 0)
                for a in lg.anchors:
                    grad.setColorAt(float(a[0]), QtGui.QColor.fromRgbF(float(a[1]), float(a[2]), float(a[3])))
                p.fillRect(QtCore.QRect(10, y, w - 20, 18), QtGui.QBrush(grad))
                for pos, text in lg.ticks:
                    x = int(10 + pos * (w - 20))
                    p.drawLine(x, y + 18, x, y + 22)
                    tw = fm.horizontalAdvance(text) if hasattr(fm, "horizontalAdvance") else fm.width(text)
                    p.drawText(max(0, min(w - tw, x - tw // 2)), y + 22 + fm.ascent(), text)
                y += 24 + line
            else:
                cols = 2
                cw = (w - 8) // cols
                for i, (rgb, text) in enumerate(lg.entries):
                    x, yy = 4 + (i % cols) * cw, y + (i // cols) * line
                    p.fillRect(x, yy, 14, 12, QtGui.QColor.fromRgbF(*rgb))
                    p.drawText(x + 18, yy + 11, text)
                y += line * ((len(lg.entries) + 1) // 2)
            p.drawText(QtCore.QRect(4, y, w - 8, self.height() - y), QtCore.Qt.TextWordWrap, lg.note)
            p.end()

    return LegendWidget(legend, parent)


def legend_to(shown, doc=None):
    """Show the colour bar of the given analyses only (bars of several would overlap).
    doc: their document (default: theirs, else the active one)."""
    import FreeCAD
    from ..app import analysis as app_analysis
    names = {a.Name for a in shown}
    doc = doc or (shown[0].Document if shown else FreeCAD.ActiveDocument)
    if doc is None:
        return
    for a in app_analysis.analyses_in(doc):
        vobj = getattr(a, "ViewObject", None)
        if vobj is not None and "ShowLegend" in vobj.PropertiesList:
            want = a.Name in names
            if vobj.ShowLegend != want:
                vobj.ShowLegend = want


def legend_after_removal(removed):
    """When the analysis carrying the colour bar goes, the bar moves to the newest analysis
    still shown in its document (its map stays on screen and needs its scale)."""
    from ..app import analysis as app_analysis
    vobj = getattr(removed, "ViewObject", None)
    if vobj is None or not getattr(vobj, "ShowLegend", False):
        return None
    shown = [a for a in app_analysis.analyses_in(removed.Document) if a.Name != removed.Name
             and getattr(a, "ViewObject", None) is not None and a.ViewObject.Visibility]
    if not shown:
        return None
    legend_to(shown[-1:], removed.Document)
    return shown[-1]


def overlay_box_pixels(legend, width, height, font_px=13.0):
    """(left, top, right, bottom) pixels, from the view's top left, that build_overlay's
    bar, ticks and title take in a view of width x height pixels (text widths estimated
    at 0.62 font_px per character, line height 1.3 font_px)."""
    def px(x, y):
        return (x + 1.0) * 0.5 * width, (1.0 - y) * 0.5 * height
    texts = [t for _, t in legend.ticks] if legend.kind == "gradient" else \
        [t.split(" (")[0] for _, t in legend.entries]
    lines = [legend.title]
    if len(legend.title) > 18 and " (" in legend.title:
        first, rest = legend.title.split(" (", 1)
        lines = [first, "(" + rest]
    char = 0.62 * font_px
    x0, y_top = px(BAR_X0, BAR_Y1 + 0.06 + 0.06 * (len(lines) - 1))
    x1, y_bot = px(BAR_X1 + 0.012, BAR_Y0 - 0.03)
    right = max(x1 + char * max(len(t) for t in texts), x0 + char * max(len(t) for t in lines))
    return x0, y_top - 1.3 * font_px, right, y_bot + 1.3 * font_px
