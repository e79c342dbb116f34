"""View provider of HullProdAnalysis: the colour-mapped hull drawn by the analysis itself.

A Coin graph built from the stored fields (points, triangles) with one colour per display
vertex (SoMaterialBinding PER_VERTEX_INDEXED on an SoIndexedFaceSet) and a screen-fixed
colour bar. The source object is never drawn on or changed.
"""
import numpy as np

from ..app import analysis as app_analysis
from . import colormaps, legend as legend_mod, wording
from .icons import icon

DISPLAY_MODE = "Colour map"
#: Uniform ambient reflectance of the coloured surface.
AMBIENT = 0.35


def face_id_values(obj):
    """{face number: face-level I_D or None} from the analysis' provenance."""
    try:
        faces = app_analysis.result_document(obj).get("provenance", {}).get("faces") or []
    except Exception:  # no results yet
        return {}
    return {int(rec["face"]): wording.face_value(rec, "I_D") for rec in faces}


def class_shares(obj):
    """Class name -> share of the area: the assessment's a_C (of the classified area) and
    the invalid share of the represented area."""
    shares = {"flat": obj.a_flat, "single": obj.a_single, "elliptic": obj.a_elliptic, "saddle": obj.a_saddle}
    rep, valid = obj.RepresentedArea, obj.ValidArea
    shares["invalid"] = 1.0 - valid / rep if rep > 0 and np.isfinite(valid) else float("nan")
    return shares


def scale_of(vobj):
    """The colormaps.Scale recorded in the view properties (defaults where absent)."""
    sc = colormaps.Scale()
    if vobj is None:
        return sc
    props = vobj.PropertiesList
    if "ScaleRange" in props:
        sc.range, sc.kind = vobj.ScaleRange, vobj.ScaleType
        sc.low, sc.high = float(vobj.ScaleMin), float(vobj.ScaleMax)
    return sc


def colors_for(obj, fields, mode, scale=None):
    """(n, 3) RGB per display vertex and the Legend for colour map mode (colormaps.MAPS)."""
    if mode == "Plates" and obj.Representation == "brep" and "face_id" in fields.extra:
        return colormaps.plate_colors(fields.extra["face_id"], face_id_values(obj), obj.Kf)
    if mode == "Change" and obj.Representation == "brep" and "face_id" in fields.extra:
        return colormaps.change_colors(fields.extra["face_id"], app_analysis.face_share_changes(obj))
    if mode == "Classes":
        return colormaps.class_colors(fields.class_id, class_shares(obj))
    if mode == "Signed":
        return colormaps.signed_colors(fields.K, fields.valid, fields.lref, obj.Kf, scale)
    rgb, lg = colormaps.developability_colors(fields.q_D, obj.Kf, scale)
    if mode in ("Plates", "Change"):
        lg.title = "no %s view: not a BRep" % ("plate" if mode == "Plates" else "change")
        lg.note = ("the %s view colours BRep faces; this analysis is of a triangle mesh, so the "
                   "developability density is shown" % ("plate" if mode == "Plates" else "change"))
    return rgb, lg


class ViewProviderHullProdAnalysis:
    """Colour maps: Developability (log10 |K| L_ref^2), Classes, Signed (K L_ref^2), Plates."""

    def __init__(self, vobj):
        vobj.Proxy = self
        self._add_properties(vobj)

    def _add_properties(self, vobj):
        if "ColorMap" not in vobj.PropertiesList:
            vobj.addProperty("App::PropertyEnumeration", "ColorMap", "HullProd", "field shown on the hull")
            vobj.ColorMap = list(colormaps.MAPS)
            from ..app import preferences
            default = preferences.get("DefaultColorMap")
            vobj.ColorMap = default if default in colormaps.MAPS else colormaps.MAPS[0]
        elif list(vobj.getEnumerationsOfProperty("ColorMap")) != list(colormaps.MAPS):  # saved with fewer maps
            shown = vobj.ColorMap
            vobj.ColorMap = list(colormaps.MAPS)
            vobj.ColorMap = shown if shown in colormaps.MAPS else colormaps.MAPS[0]
        if "ShowLegend" not in vobj.PropertiesList:
            vobj.addProperty("App::PropertyBool", "ShowLegend", "HullProd", "colour bar in the 3D view")
            vobj.ShowLegend = True
        if "ScaleRange" not in vobj.PropertiesList:
            vobj.addProperty("App::PropertyEnumeration", "ScaleRange", "HullProd scale",
                             "range of the developability and signed maps: two percentiles of the samples "
                             "above k_f, k_f to the 99.5th percentile, or ScaleMin to ScaleMax")
            vobj.ScaleRange = list(colormaps.SCALE_RANGES)
            vobj.addProperty("App::PropertyEnumeration", "ScaleType", "HullProd scale",
                             "logarithmic or linear colour scale")
            vobj.ScaleType = list(colormaps.SCALE_TYPES)
            vobj.addProperty("App::PropertyFloat", "ScaleMin", "HullProd scale", "fixed range: lowest |K| L_ref^2")
            vobj.addProperty("App::PropertyFloat", "ScaleMax", "HullProd scale", "fixed range: highest |K| L_ref^2")
            vobj.ScaleMin, vobj.ScaleMax = colormaps.Scale.low, colormaps.Scale.high

    # -- Coin graph ---------------------------------------------------------------------------
    def attach(self, vobj):
        from pivy import coin
        from . import live_update
        live_update.install()  # a recompute of an AutoUpdate analysis reassesses it in the background
        self._add_properties(vobj)  # a document saved before a property existed
        self.ViewObject = vobj
        self.Object = vobj.Object
        self.colors = np.zeros((0, 3))
        self.legend = None
        self.root = coin.SoSeparator()
        offset = coin.SoPolygonOffset()  # drawn just in front of a coincident source surface
        offset.factor = -1.0
        offset.units = -1.0
        hints = coin.SoShapeHints()
        hints.vertexOrdering = coin.SoShapeHints.COUNTERCLOCKWISE
        hints.shapeType = coin.SoShapeHints.UNKNOWN_SHAPE_TYPE  # two-sided lighting
        hints.creaseAngle = 0.9
        self.binding = coin.SoMaterialBinding()
        self.binding.value = coin.SoMaterialBinding.PER_VERTEX_INDEXED
        self.material = coin.SoMaterial()
        self.coords = coin.SoCoordinate3()
        self.faceset = coin.SoIndexedFaceSet()
        self.legend_switch = coin.SoSwitch()
        self.marker_sep = coin.SoSeparator()
        for node in (offset, hints, self.binding, self.material, self.coords, self.faceset):
            self.root.addChild(node)
        top = coin.SoSeparator()
        top.addChild(self.root)
        top.addChild(self.marker_sep)
        top.addChild(legend_mod.unbounded(self.legend_switch))
        vobj.addDisplayMode(top, DISPLAY_MODE)
        self.rebuild()

    def rebuild(self):
        """Geometry from the stored fields, then the colours."""
        obj = getattr(self, "Object", None)
        if obj is None or not hasattr(self, "coords"):
            return
        fields = app_analysis.analysis_fields(obj)
        self.coords.point.setNum(0)
        self.faceset.coordIndex.setNum(0)
        if fields is None or not len(fields.triangles):
            self.colors = np.zeros((0, 3))
            self.material.diffuseColor.setNum(0)
            self.legend_switch.removeAllChildren()
            return
        pts = np.asarray(fields.points, float)
        tri = np.asarray(fields.triangles, np.int64)
        self.coords.point.setValues(0, len(pts), pts.tolist())
        idx = np.column_stack([tri, -np.ones(len(tri), np.int64)]).ravel().tolist()
        self.faceset.coordIndex.setValues(0, len(idx), idx)
        self.faceset.materialIndex.setValues(0, len(idx), idx)
        self.recolor(fields)

    def recolor(self, fields=None):
        """Colours of the current ColorMap, one per display vertex, and the colour bar."""
        obj = getattr(self, "Object", None)
        if obj is None or not hasattr(self, "material"):
            return
        fields = fields or app_analysis.analysis_fields(obj)
        if fields is None:
            return
        rgb, lg = colors_for(obj, fields, getattr(self.ViewObject, "ColorMap", colormaps.MAPS[0]),
                             scale_of(self.ViewObject))
        self.colors, self.legend = rgb, lg
        # Only the diffuse colour varies per vertex in Coin; the other material fields are
        # uniform, so a grey ambient keeps surfaces turned away from the light readable.
        self.material.diffuseColor.setValues(0, len(rgb), rgb.tolist())
        self.material.diffuseColor.setNum(len(rgb))
        self.material.ambientColor.setValue(AMBIENT, AMBIENT, AMBIENT)
        self.legend_switch.removeAllChildren()
        self.legend_switch.addChild(legend_mod.build_overlay(lg))
        from pivy import coin
        self.legend_switch.whichChild = coin.SO_SWITCH_ALL if getattr(self.ViewObject, "ShowLegend", True) else coin.SO_SWITCH_NONE

    def coin_colors(self):
        """(k, 3) per-vertex diffuse colours currently in the Coin material (what is drawn)."""
        return np.array([c.getValue() for c in self.material.diffuseColor.getValues()], float).reshape(-1, 3)

    def show_marker(self, point, radius):
        """A small sphere at a probed point."""
        from pivy import coin
        self.marker_sep.removeAllChildren()
        mat = coin.SoBaseColor()
        mat.rgb.setValue(0.05, 0.05, 0.05)
        tr = coin.SoTranslation()
        tr.translation.setValue(*[float(x) for x in point])
        sph = coin.SoSphere()
        sph.radius = float(radius)
        for node in (mat, tr, sph):
            self.marker_sep.addChild(node)

    def clear_marker(self):
        """Remove the probe's marker sphere."""
        if hasattr(self, "marker_sep"):
            self.marker_sep.removeAllChildren()

    # -- FreeCAD hooks ------------------------------------------------------------------------
    def updateData(self, obj, prop):
        if prop == "FieldsFile":
            self.rebuild()
        elif prop in ("ResultJSON", "Kf"):
            self.recolor()

    def onChanged(self, vobj, prop):
        if prop == "ShowLegend" and vobj.ShowLegend:
            self._sole_legend(vobj)
        if prop in ("ColorMap", "ShowLegend", "ScaleRange", "ScaleType", "ScaleMin", "ScaleMax"):
            self.recolor()

    @staticmethod
    def _sole_legend(vobj):
        """A colour bar turned on (a new analysis, a macro) turns off the others of its
        document: bars drawn at the same place of the view would overlap."""
        obj = getattr(vobj, "Object", None)
        doc = getattr(obj, "Document", None)
        if doc is None or getattr(doc, "Restoring", False):
            return
        from .legend import legend_to
        legend_to([obj], doc)

    def getDisplayModes(self, vobj):
        return [DISPLAY_MODE]

    def getDefaultDisplayMode(self):
        return DISPLAY_MODE

    def setDisplayMode(self, mode):
        return mode

    def getIcon(self):
        return icon("HullProd_Analyze")

    def doubleClicked(self, vobj):
        from .validity_panel import show_validity_panel
        show_validity_panel(vobj.Object)
        return True

    def setupContextMenu(self, vobj, menu):
        from .qt import QtGui, QtWidgets
        action_cls = getattr(QtGui, "QAction", None) or QtWidgets.QAction
        for mode in colormaps.MAPS:
            act = action_cls("Colour map: %s" % mode, menu)
            act.triggered.connect(lambda checked=False, m=mode: setattr(vobj, "ColorMap", m))
            menu.addAction(act)
        act = action_cls("Validity and provenance...", menu)
        act.triggered.connect(lambda checked=False: self.doubleClicked(vobj))
        menu.addAction(act)

    def onDelete(self, vobj, subelements):
        """Show the source again when its last analysis goes (Analyze may have hidden it);
        the colour bar moves to an analysis still shown."""
        obj = vobj.Object
        from . import live_update
        live_update.cancel(obj)
        legend_mod.legend_after_removal(obj)
        src = getattr(obj, "Source", None)
        if src is not None and getattr(src, "ViewObject", None) is not None:
            others = [a for a in app_analysis.analyses_in(obj.Document) if a.Name != obj.Name and a.Source == src]
            if not others:
                src.ViewObject.Visibility = True
        return True

    def __getstate__(self):
        return None

    def __setstate__(self, state):
        return None

    def dumps(self):
        return None

    def loads(self, state):
        return None
