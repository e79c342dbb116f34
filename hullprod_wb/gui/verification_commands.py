"""The 'Verification' menu: the paper's verification studies (section 5) on the source of
a selected analysis, with progress, written as an HTML report and opened in the browser.

HullProd_StudySameFace, HullProd_StudyRefinement, HullProd_StudyRepresentation,
HullProd_StudyThresholds. The numerics are hullprod_wb.studies; this module only presents.
"""
import os
import tempfile
import webbrowser

import FreeCAD
import FreeCADGui

from ..app.progress import RunProgress
from ..core.errors import InputError
from . import dialogs
from .commands import _Command, selected_analyses


def study_arguments(analysis):
    """(source object, faces or None, explicit L_ref or None) of an analysis object."""
    src = analysis.Source
    if src is None:
        raise InputError("the analysis %s has no source object" % analysis.Label)
    faces = list(analysis.Faces) or None
    lref = analysis.LrefUsed if analysis.LrefUsed == analysis.LrefUsed and analysis.LrefUsed > 0 else None
    return src, faces, lref


class _Study(_Command):
    kind = ""

    def IsActive(self):  # noqa: N802 - FreeCAD API
        return FreeCAD.ActiveDocument is not None

    def compute(self, src, faces, lref, progress):
        raise NotImplementedError

    def run(self):
        analysis = selected_analyses()[0]
        src, faces, lref = study_arguments(analysis)
        if not hasattr(src, "Shape") and self.kind != "thresholds":
            raise InputError("this study needs a BRep (Part) source; %s is a mesh" % src.Label)
        progress = RunProgress("HullProd %s study" % self.kind)
        try:
            study = self.compute(src, faces, lref, progress)
        finally:
            progress.stop()
        from ..studies import write_report
        folder = tempfile.mkdtemp(prefix="hullprod-%s-" % self.kind)
        path = write_report(None, os.path.join(folder, "report.html"), studies=study)
        headline = ""
        if self.kind == "sameface":
            from ..studies.cli import sameface_summary
            headline = "\n".join(sameface_summary(study)[:2]) + "\n"
        FreeCAD.Console.PrintMessage("HullProd %s study of %s: %s\n%s" % (self.kind, src.Label, path, headline))
        if dialogs.INTERACTIVE:
            webbrowser.open("file://" + path)
        dialogs.info("%s study" % self.kind, "%sReport written to\n%s" % (headline, path))


class StudySameFace(_Study):
    name = "HullProd_StudySameFace"
    menu = "Same-face curvature &recovery"
    tip = ("BRep-to-mesh curvature recovery on 12x12, 24x24, 48x48 grids of each face (eps_H, eps_K); "
           "headline: the face of largest area, with the largest-|K| face beside it")
    kind = "sameface"

    def compute(self, src, faces, lref, progress):
        from ..studies import sameface_study
        return sameface_study(src.Shape, faces=faces, progress=progress)


class StudyRefinement(_Study):
    name = "HullProd_StudyRefinement"
    menu = "Mesh-&resolution sensitivity"
    tip = "Signature on three tessellations of the BRep, changes and class distance d1 against the finest"
    kind = "refinement"

    def compute(self, src, faces, lref, progress):
        from ..studies import refinement_study
        return refinement_study(src.Shape, lref=lref, faces=faces, progress=progress)


class StudyRepresentation(_Study):
    name = "HullProd_StudyRepresentation"
    menu = "Re&presentation: BRep against mesh"
    tip = "Native BRep signature next to a fine triangulated realization of the same hull"
    kind = "representation"

    def compute(self, src, faces, lref, progress):
        from ..studies import representation_study
        return representation_study(src.Shape, lref=lref, faces=faces, progress=progress)


class StudyThresholds(_Study):
    name = "HullProd_StudyThresholds"
    menu = "&Threshold study"
    tip = "Class fractions for h_f = k_f = 1e-5, 1e-4, 1e-3; I_D is threshold independent"
    kind = "thresholds"

    def compute(self, src, faces, lref, progress):
        from ..studies import threshold_study
        return threshold_study(src.Shape if hasattr(src, "Shape") else src, lref=lref, faces=faces,
                               progress=progress)


COMMANDS = [StudySameFace, StudyRefinement, StudyRepresentation, StudyThresholds]
MENU = [c.name for c in COMMANDS]
_REGISTERED = False


def register():
    global _REGISTERED
    if not _REGISTERED:
        for cls in COMMANDS:
            FreeCADGui.addCommand(cls.name, cls())
        _REGISTERED = True
    return MENU
