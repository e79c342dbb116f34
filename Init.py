# HullProd workbench: application-side initialisation (runs in FreeCAD and FreeCADCmd).
# Executed by FreeCAD without __file__; the package hullprod_wb is importable from this Mod folder.
# Nothing heavy happens here: the numerics load when first used.
import FreeCAD

# The self-test in FreeCAD's test runner: freecadcmd -t TestHullProd, or the Test workbench.
FreeCAD.__unit_test__ += ["TestHullProd"]
