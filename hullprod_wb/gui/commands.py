"""The workbench commands (stable names, usable from macros with FreeCADGui.runCommand).

HullProd_Analyze, HullProd_ShowDevelopability, HullProd_ShowClasses,
HullProd_ShowSignedDevelopability, HullProd_ShowPlates, HullProd_ValidityPanel,
HullProd_Probe, HullProd_Compare, HullProd_Export.
"""
import os

import FreeCAD
import FreeCADGui

from ..app import analysis as app_analysis
from ..app.export import export_analysis
from ..app.selection import analyses_from_selection, ignored_subelements, sources_from_selection
from ..core.errors import InputError
from . import dialogs
from .icons import icon
from .legend import legend_to


def _clean(exc):
    return " ".join(str(exc).split()) or type(exc).__name__


def selected_analyses(allow_single_in_document=True):
    """Analyses in the selection; with none selected, the document's only analysis."""
    found = analyses_from_selection(FreeCADGui.Selection.getSelection())
    if not found and allow_single_in_document and FreeCAD.ActiveDocument is not None:
        every = app_analysis.analyses_in(FreeCAD.ActiveDocument)
        if len(every) == 1:
            found = every
    if not found:
        raise InputError("select a HullProd analysis in the tree first (run Analyze to make one)")
    return found


class _Command:
    """Base: resources from class attributes; errors go to the report view and a dialog."""

    name = ""
    menu = ""
    tip = ""
    accel = ""

    def GetResources(self):  # noqa: N802 - FreeCAD API
        # ForEdit: usable while a task panel (validity, compare, probe) is open
        res = {"Pixmap": icon(self.name), "MenuText": self.menu, "ToolTip": self.tip, "CmdType": "ForEdit"}
        if self.accel:
            res["Accel"] = self.accel
        return res

    def IsActive(self):  # noqa: N802 - FreeCAD API
        return FreeCAD.ActiveDocument is not None

    def Activated(self):  # noqa: N802 - FreeCAD API
        try:
            self.run()
        except Exception as exc:  # a command never crashes the GUI
            dialogs.error(self.menu.replace("&", ""), _clean(exc))

    def run(self):
        raise NotImplementedError


class Analyze(_Command):
    name = "HullProd_Analyze"
    menu = "&Analyze"
    tip = ("Producibility signature of the selected Part objects, faces of a Part, or Mesh objects: "
           "developability, curvature classes and validity")

    def run(self):
        sel = [(s.Object, list(s.SubElementNames)) for s in FreeCADGui.Selection.getSelectionEx()]
        sources = sources_from_selection(sel)
        ignored = ["%s.%s" % (o.Label, n) for o, subs in sel if hasattr(o, "Shape")
                   for n in ignored_subelements(subs)]
        from .analyze_panel import show_analyze_panel
        show_analyze_panel(sources, ignored)


class _ShowMap(_Command):
    mode = ""

    def run(self):
        found = selected_analyses()
        if self.mode == "Plates":
            meshes = [a for a in found if a.Representation != "brep"]
            if meshes:
                dialogs.info("plate view", "The plate view colours each BRep face by its own I_D; %s %s a "
                             "triangle mesh, which has no faces to colour. Its map is unchanged."
                             % (", ".join(a.Label for a in meshes), "is" if len(meshes) == 1 else "are"))
            found = [a for a in found if a not in meshes]
            if not found:
                return
        for a in found:
            a.ViewObject.ColorMap = self.mode
            a.ViewObject.Visibility = True
        FreeCADGui.Selection.clearSelection()  # the selection highlight would tint the map
        legend_to(found[-1:])


class ShowDevelopability(_ShowMap):
    name = "HullProd_ShowDevelopability"
    menu = "Show &developability density"
    tip = "Colour the analysed hull by log10(|K| L_ref^2), the developability density"
    mode = "Developability"


class ShowClasses(_ShowMap):
    name = "HullProd_ShowClasses"
    menu = "Show curvature &classes"
    tip = "Colour the analysed hull by curvature class: flat, single, elliptic, saddle (grey: invalid)"
    mode = "Classes"


class ShowSignedDevelopability(_ShowMap):
    name = "HullProd_ShowSignedDevelopability"
    menu = "Show &signed developability"
    tip = "Colour the analysed hull by K L_ref^2: saddle (blue) against elliptic (red)"
    mode = "Signed"


class ShowPlates(_ShowMap):
    name = "HullProd_ShowPlates"
    menu = "Show &plates (per face)"
    tip = "BRep: colour each face by its own face-level I_D (the table is in the validity panel)"
    mode = "Plates"


class ValidityPanelCommand(_Command):
    name = "HullProd_ValidityPanel"
    menu = "&Validity and provenance"
    tip = "Signature values with their validity, reasons, evidence and provenance; copy the JSON"

    def run(self):
        from .validity_panel import show_validity_panel
        show_validity_panel(selected_analyses()[0])


class Probe(_Command):
    name = "HullProd_Probe"
    menu = "&Probe curvature"
    tip = "Click points of an analysed hull to read K, H, k1, k2, q_D and the class there"

    def run(self):
        from .probe import start_probe
        found = analyses_from_selection(FreeCADGui.Selection.getSelection()) or \
            app_analysis.analyses_in(FreeCAD.ActiveDocument)
        if not found:
            raise InputError("there is no HullProd analysis in this document to probe")
        start_probe(found)


class Compare(_Command):
    name = "HullProd_Compare"
    menu = "&Compare analyses"
    tip = ("Analyses of every open document side by side (the selected ones ticked), flagging "
           "comparisons that are not like for like")

    def run(self):
        from ..app.compare import open_analyses
        every = open_analyses()
        if len(every) < 2:
            raise InputError("there %s %d HullProd analysis in the open documents: Compare needs two or more "
                             "(run Analyze on another hull, or open its document)"
                             % ("is" if len(every) == 1 else "are", len(every)))
        chosen = analyses_from_selection(FreeCADGui.Selection.getSelection("*"))
        from .compare_panel import show_compare_panel
        show_compare_panel(chosen if len(chosen) >= 2 else every, every)


class Export(_Command):
    name = "HullProd_Export"
    menu = "&Export results"
    tip = "Write signature.json, signature.csv, fields.vtp and fields.csv of the selected analyses"

    def run(self):
        found = selected_analyses()
        start = os.path.dirname(FreeCAD.ActiveDocument.FileName or "") or os.path.expanduser("~")
        folder = dialogs.ask_directory("Folder for the HullProd results", start)
        if not folder:
            return
        written = []
        for a in found:
            target = os.path.join(folder, a.Label)
            overwrite = False
            if os.path.isdir(target) and os.listdir(target):
                overwrite = dialogs.ask_yes_no("export", "%s is not empty. Overwrite?" % target)
                if not overwrite:
                    continue
            paths = export_analysis(a, target, overwrite=overwrite)
            written.append("%s:\n  %s" % (a.Label, "\n  ".join(paths.values())))
        if written:
            dialogs.info("export", "Wrote\n" + "\n".join(written))


COMMANDS = [Analyze, ShowDevelopability, ShowClasses, ShowSignedDevelopability, ShowPlates,
            ValidityPanelCommand, Probe, Compare, Export]
#: Command names in toolbar order (None: separator).
TOOLBAR = ["HullProd_Analyze", "Separator", "HullProd_ShowDevelopability", "HullProd_ShowClasses",
           "HullProd_ShowSignedDevelopability", "HullProd_ShowPlates", "Separator", "HullProd_ValidityPanel",
           "HullProd_Probe", "HullProd_Compare", "HullProd_Export"]

_REGISTERED = False


def register():
    """Add every command to FreeCAD once."""
    global _REGISTERED
    if _REGISTERED:
        return [c.name for c in COMMANDS]
    for cls in COMMANDS:
        FreeCADGui.addCommand(cls.name, cls())
    _REGISTERED = True
    return [c.name for c in COMMANDS]
