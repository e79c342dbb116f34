"""Locate and import FreeCAD's Python modules from any Python 3 interpreter.

FreeCAD must be imported before Part (the other order crashes the interpreter), and
from a plain interpreter its library folder must be on ``sys.path`` first.
"""
import os
import sys

from .core.errors import FreeCADUnavailable

#: Folders searched for FreeCAD.so, most specific first.
FREECAD_LIB_DIRS = (
    os.environ.get("HULLPROD_FREECAD_LIB", ""),
    "/usr/lib/freecad-python3/lib",
    "/usr/lib/freecad/lib",
    "/usr/local/lib/freecad/lib",
)


def import_freecad():
    """Return the ``FreeCAD`` module, importing it (and ``Part``) in the safe order."""
    if "FreeCAD" in sys.modules:
        import FreeCAD  # noqa: F401
        import Part  # noqa: F401
        return FreeCAD
    for folder in FREECAD_LIB_DIRS:
        if folder and os.path.isfile(os.path.join(folder, "FreeCAD.so")) and folder not in sys.path:
            sys.path.append(folder)
    try:
        import FreeCAD  # noqa: F401
        import Part  # noqa: F401
    except ImportError as exc:
        raise FreeCADUnavailable(
            "FreeCAD's Python modules are not importable (%s); install the Debian package "
            "'freecad' or set HULLPROD_FREECAD_LIB to the folder holding FreeCAD.so" % exc
        ) from exc
    return FreeCAD


def freecad_available():
    """True when FreeCAD can be imported here."""
    try:
        import_freecad()
    except FreeCADUnavailable:
        return False
    return True


#: Versions reported by the process that read the input (record_reader), when this one has
#: not loaded FreeCAD itself.
_REPORTED = None


def set_reported_versions(reported):
    """Record the FreeCAD and OpenCascade versions of the process that read the input."""
    global _REPORTED
    _REPORTED = dict(reported) if reported else None


def user_cache_folder():
    """FreeCAD's user cache folder (App.getUserCachePath) when FreeCAD is loaded here, else
    None."""
    if "FreeCAD" not in sys.modules:
        return None
    try:
        return str(sys.modules["FreeCAD"].getUserCachePath())
    except Exception:  # a FreeCAD without it
        return None


def versions(load=True):
    """FreeCAD and OpenCascade versions as strings, or None where FreeCAD is absent (those
    of the reading process, set_reported_versions, when FreeCAD is not loaded here). With
    load False, None unless FreeCAD is loaded already or reported (a computation that does
    not use it: FreeCAD is not imported for it)."""
    if _REPORTED is not None and "FreeCAD" not in sys.modules:
        return dict(_REPORTED)
    if not load and "FreeCAD" not in sys.modules:
        return {"FreeCAD": None, "OCC": None}
    try:
        FreeCAD = import_freecad()
        import Part
    except FreeCADUnavailable:
        return {"FreeCAD": None, "OCC": None}
    return {"FreeCAD": ".".join(FreeCAD.Version()[:3]), "OCC": getattr(Part, "OCC_VERSION", None)}
