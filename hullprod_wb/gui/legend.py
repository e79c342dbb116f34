"""Colour bars and legends: a Coin overlay fixed to the 3D view, and a Qt widget.

Both draw a colormaps.Legend; neither computes anything.
"""
import numpy as np

from . import colormaps

#: The overlay lives in a tiny normalised box (side 2 * HUD_SCALE model units around the
#: origin) seen through its own orthographic camera, so it never enlarges "fit all".
HUD_SCALE = 1.0e-6
#: Overlay layout in normalised device coordinates ([-1, 1] across the view).
BAR_X0, BAR_X1, BAR_Y0, BAR_Y1 = 0.80, 0.845, -0.55, 0.55


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
    head.addChild(_text(coin, 0.98, top + 0.06 * (len(lines) - 1), lines, coin.SoText2.RIGHT))
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
            self.setMinimumHeight(70 if legend.kind == "gradient" else 24 + 18 * ((len(legend.entries) + 2) // 3))

        def set_legend(self, legend):
            self.legend = legend
            self.update()

        def paintEvent(self, event):  # noqa: N802 - Qt API
            lg = self.legend
            p = QtGui.QPainter(self)
            w = self.width()
            p.drawText(4, 14, lg.title)
            if lg.kind == "gradient":
                grad = QtGui.QLinearGradient(10, 0, w - 10, 0)
                for a in lg.anchors:
                    grad.setColorAt(float(a[0]), QtGui.QColor.fromRgbF(float(a[1]), float(a[2]), float(a[3])))
                p.fillRect(QtCore.QRect(10, 20, w - 20, 18), QtGui.QBrush(grad))
                for pos, text in lg.ticks:
                    x = int(10 + pos * (w - 20))
                    p.drawLine(x, 38, x, 42)
                    tw = p.fontMetrics().horizontalAdvance(text) if hasattr(p.fontMetrics(), "horizontalAdvance") \
                        else p.fontMetrics().width(text)
                    p.drawText(max(0, min(w - tw, x - tw // 2)), 55, text)
                p.drawText(4, 68, lg.note)
            else:
                cols = 3
                cw = (w - 8) // cols
                for i, (rgb, text) in enumerate(lg.entries):
                    x, y = 4 + (i % cols) * cw, 22 + (i // cols) * 18
                    p.fillRect(x, y, 14, 12, QtGui.QColor.fromRgbF(*rgb))
                    p.drawText(x + 18, y + 11, text)
            p.end()

    return LegendWidget(legend, parent)
