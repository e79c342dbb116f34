"""HullProd: geometry-based producibility signature of hull surfaces for FreeCAD.

Python use (inside FreeCAD, FreeCADCmd or /usr/bin/python3 with FreeCAD's modules)::

    import hullprod_wb
    r = hullprod_wb.assess("hull.step", lref=5720.0)
    r.signature, r.validity, r.to_json(), r.save("out")
"""
__version__ = "0.1.0"

from .api import assess  # noqa: E402,F401
from .core.errors import InputError  # noqa: E402,F401
