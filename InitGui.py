# HullProd workbench: GUI-side registration. Executed by FreeCAD without __file__.
import FreeCAD
import FreeCADGui


class HullProdWorkbench(FreeCADGui.Workbench):
    """Producibility signature of hull surfaces: developability, curvature classes, validity."""

    MenuText = "HullProd"
    ToolTip = "Geometry-based producibility screening of hull surfaces"

    def __init__(self):
        import os
        import hullprod_wb
        self.__class__.Icon = os.path.join(os.path.dirname(os.path.dirname(hullprod_wb.__file__)),
                                           "resources", "icons", "HullProd.svg")

    def Initialize(self):
        from hullprod_wb.gui import workbench_setup
        workbench_setup.initialize(self)

    def Activated(self):
        pass

    def Deactivated(self):
        pass

    def GetClassName(self):
        return "Gui::PythonWorkbench"


FreeCADGui.addWorkbench(HullProdWorkbench())
# The GUI self-test in the Test workbench (its App half is registered in Init.py).
FreeCAD.__unit_test__ += ["TestHullProdGui"]
