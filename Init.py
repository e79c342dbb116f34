# HullProd workbench: application-side initialisation (runs in FreeCAD and FreeCADCmd).
# Executed by FreeCAD without __file__; the package hullprod_wb is importable from this Mod folder.
# Nothing heavy happens here: the numerics load when first used.
