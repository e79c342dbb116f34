"""HullProd: geometry-based producibility signature of hull surfaces for FreeCAD."""
__version__ = "0.1.0"
