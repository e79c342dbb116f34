"""HullProd: geometry-based producibility signature of hull surfaces for FreeCAD.

Python use (inside FreeCAD, FreeCADCmd or /usr/bin/python3 with FreeCAD's modules)::

    import hullprod_wb
    r = hullprod_wb.assess("hull.step", lref=5720.0)
    r.signature, r.validity, r.to_json(), r.save("out")
    obj = hullprod_wb.make_analysis(doc_object, lref=5720.0)   # parametric document object
    table = hullprod_wb.assess_many(["a.step", "b.stl"], workers=2)
"""
from .core.errors import InputError  # noqa: F401
from .core.version import __version__  # noqa: F401


def __getattr__(name):
    """hullprod_wb.assess, imported on first use (the command line starts a file's reading
    process before it loads the API)."""
    if name == "assess":
        from .api import assess
        return assess
    raise AttributeError("module 'hullprod_wb' has no attribute %r" % name)


def make_analysis(source, faces=None, lref=None, doc=None, **options):
    """Create a parametric HullProdAnalysis document object for source (see hullprod_wb.app)."""
    from .app import make_analysis as _make
    return _make(source, faces=faces, lref=lref, doc=doc, **options)


def assess_many(sources, workers=None, scheduler=None, out=None, **options):
    """Assess many hulls locally in parallel or on a Dask cluster (see hullprod_wb.batch)."""
    from .batch import assess_many as _many
    return _many(sources, workers=workers, scheduler=scheduler, out=out, **options)
