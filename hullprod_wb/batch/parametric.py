"""Variants of a parametric hull in a FreeCAD document.

A variant sets named parameters, each a spreadsheet cell alias (``L``, or ``Sheet.L`` to
name the spreadsheet) or an object property (``Body.Length`` with the object's Name or
Label), on a private copy of the document opened fresh from the file, recomputes it and
hands back the hull object's shape. The document file is never saved or modified, and a
document of the same file open in the GUI is not touched.
"""
import contextlib
import os
import shutil
import tempfile

from ..core.errors import InputError
from ..freecad_env import import_freecad

SHEET_TYPE = "Spreadsheet::Sheet"


def _object(doc, name):
    """Document object by Name, else by unique Label (None when absent)."""
    obj = doc.getObject(name)
    if obj is not None:
        return obj
    found = doc.getObjectsByLabel(name)
    if len(found) > 1:
        raise InputError("%s: more than one object is labelled %r; use its Name" % (_where(doc), name))
    return found[0] if found else None


def _sheets(doc):
    return [o for o in doc.Objects if o.TypeId == SHEET_TYPE]


def _alias_cell(sheet, alias):
    try:
        return sheet.getCellFromAlias(alias)
    except Exception:  # older FreeCAD raises when the alias is unknown
        return None


def resolve_parameter(doc, name):
    """Where parameter `name` lives: ('alias', sheet, cell) or ('property', object, property).

    'L' is an alias of exactly one spreadsheet; 'Sheet.L' an alias of the spreadsheet
    Sheet; 'Obj.Prop' a property of the object with Name or Label Obj.
    """
    if "." not in name:
        hits = [(s, c) for s in _sheets(doc) for c in [_alias_cell(s, name)] if c]
        if not hits:
            raise InputError("%s: no spreadsheet has a cell with alias %r (parameter column %r)"
                             % (_where(doc), name, name))
        if len(hits) > 1:
            raise InputError("%s: alias %r exists in several spreadsheets (%s); write Sheet.%s"
                             % (_where(doc), name, ", ".join(s.Name for s, _ in hits), name))
        return ("alias",) + hits[0]
    owner, prop = name.rsplit(".", 1)
    obj = _object(doc, owner)
    if obj is None:
        raise InputError("%s: no object named or labelled %r (parameter column %r)" % (_where(doc), owner, name))
    if obj.TypeId == SHEET_TYPE:
        cell = _alias_cell(obj, prop)
        if cell:
            return ("alias", obj, cell)
    if prop not in obj.PropertiesList:
        raise InputError("%s: object %s has no property %r (parameter column %r)" % (_where(doc), obj.Name, prop, name))
    bound = dict(obj.ExpressionEngine).get(prop)
    if bound is not None:
        raise InputError("%s: %s.%s is driven by the expression %r and would be overwritten on "
                         "recompute; set what drives it instead" % (_where(doc), obj.Name, prop, bound))
    return ("property", obj, prop)


def set_parameter(doc, name, value):
    """Set one parameter (see resolve_parameter); numbers in the document's units."""
    kind, owner, key = resolve_parameter(doc, name)
    if kind == "alias":
        owner.set(key, str(value))
        return
    try:
        setattr(owner, key, value)
    except Exception as exc:
        raise InputError("%s: cannot set %s.%s = %r: %s" % (_where(doc), owner.Name, key, value, exc)) from None


def _area(obj):
    shape = getattr(obj, "Shape", None)
    try:
        if shape is None or shape.isNull() or not shape.Faces:
            return 0.0
        return shape.Area
    except Exception:  # OpenCascade cannot compute the area of one of its faces
        return 0.0


def pick_hull_object(doc, name=None):
    """The object to assess: `name` (Name or Label) or the visible object with the largest-area shape."""
    if name:
        obj = _object(doc, name)
        if obj is None:
            raise InputError("%s: no object named or labelled %r (--object)" % (_where(doc), name))
        if not hasattr(obj, "Shape") and not hasattr(obj, "Mesh"):
            raise InputError("%s: object %s has neither a Part shape nor a mesh" % (_where(doc), name))
        return obj
    shaped = [o for o in doc.Objects if getattr(o, "Visibility", True) and _area(o) > 0]
    if not shaped:
        raise InputError("%s: no visible object with a surface shape; name one with --object" % _where(doc))
    return max(shaped, key=_area)


def recompute(doc):
    """Recompute doc; InputError naming the objects that failed."""
    doc.recompute()
    bad = [o for o in doc.Objects if "Invalid" in o.State or "Error" in o.State]
    if bad:
        raise InputError("%s: recompute failed for %s" % (
            _where(doc), ", ".join("%s (%s)" % (o.Name, ",".join(o.State)) for o in bad)))


#: Document name -> path of the file it is a copy of (for messages).
_ORIGINAL = {}


def _where(doc):
    return _ORIGINAL.get(doc.Name, doc.FileName)


@contextlib.contextmanager
def open_document(path):
    """Open a private copy of the document at path; close and delete it afterwards.

    The copy (same file name, in a temporary folder) keeps the file on disk and any open
    document of the same file (e.g. in the GUI) untouched. Documents that link other files
    by relative path are not supported.
    """
    FreeCAD = import_freecad()
    path = os.path.abspath(path)
    if not os.path.isfile(path):
        raise InputError("FreeCAD document not found: %s" % path)
    tmpdir = tempfile.mkdtemp(prefix="hullprod-variant-")
    copy = os.path.join(tmpdir, os.path.basename(path))
    try:
        shutil.copyfile(path, copy)
        try:
            doc = FreeCAD.openDocument(copy)
        except Exception as exc:
            raise InputError("cannot open FreeCAD document %s: %s"
                             % (path, " ".join(str(exc).replace(copy, path).split()))) from None
        _ORIGINAL[doc.Name] = path
        try:
            yield doc
        finally:
            _ORIGINAL.pop(doc.Name, None)
            FreeCAD.closeDocument(doc.Name)
    finally:
        shutil.rmtree(tmpdir, ignore_errors=True)


@contextlib.contextmanager
def variant_object(path, params, object_name=None):
    """Document at path with params applied and recomputed; yields the hull object.

    The object is only valid inside the block (the document closes on exit).
    """
    with open_document(path) as doc:
        for name, value in params.items():
            set_parameter(doc, name, value)
        recompute(doc)
        yield pick_hull_object(doc, object_name)


def check_document(path, names, object_name=None):
    """Open the document once and check that every parameter and the object resolve."""
    with open_document(path) as doc:
        for name in names:
            resolve_parameter(doc, name)
        pick_hull_object(doc, object_name)


class DocumentHull:
    """Callable x -> Part.Shape of a document's hull with parameters names[i] = x[i].

    For SignatureObjective: each call opens the document fresh, sets the parameters,
    recomputes and returns a copy of the hull shape (valid after the document closes).
    Picklable, so it can travel to worker processes.
    """

    def __init__(self, path, names, object_name=None):
        self.path = os.path.abspath(path)
        self.names = list(names)
        self.object_name = object_name

    def __call__(self, x):
        values = [float(v) for v in x]
        if len(values) != len(self.names):
            raise InputError("expected %d parameter values (%s), got %d"
                             % (len(self.names), ", ".join(self.names), len(values)))
        with variant_object(self.path, dict(zip(self.names, values)), self.object_name) as obj:
            if not hasattr(obj, "Shape"):
                raise InputError("%s: the hull object %s has no Part shape" % (self.path, obj.Name))
            return obj.Shape.copy()
