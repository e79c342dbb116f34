"""FreeCAD documents (.FCStd) as input: one Part or Mesh object of the document, opened
headless from a private copy (batch.parametric.open_document), so that the file and any
document of it open in the GUI are never modified or saved.

The object is named (Name or Label), or else the document's one shape-bearing top-level
object (an object no other object uses); of several, the one that is visible when only one
is; otherwise the choice is the user's (InputError listing them).
"""
import os
from contextlib import contextmanager

from .batch.parametric import open_document
from .core.errors import InputError
from .core.inputs import sha256_file


def _bears_shape(obj):
    """Whether obj carries a Part shape with faces or a mesh with facets."""
    try:
        shape = getattr(obj, "Shape", None)
        if shape is not None and not shape.isNull() and shape.Faces:
            return True
        mesh = getattr(obj, "Mesh", None)
        return mesh is not None and hasattr(mesh, "CountFacets") and mesh.CountFacets > 0
    except Exception:  # a property that cannot be read: not a hull to assess
        return False


def _describe(objs):
    return ", ".join("%s (label %r%s)" % (o.Name, o.Label, "" if getattr(o, "Visibility", True) else ", hidden")
                     for o in objs)


def pick_object(doc, path, name=None):
    """(object, how it was chosen) of doc (see the module doc); InputError when none fits."""
    if name:
        from .batch.parametric import _object
        obj = _object(doc, name)
        if obj is None:
            raise InputError("%s: no object named or labelled %r (--object); shape-bearing objects: %s"
                             % (path, name, _describe([o for o in doc.Objects if _bears_shape(o)]) or "none"))
        if not _bears_shape(obj):
            raise InputError("%s: object %s (label %r) has neither a Part shape with faces nor a mesh"
                             % (path, obj.Name, obj.Label))
        return obj, "named (--object %s)" % name
    top = [o for o in doc.Objects if not o.InList and _bears_shape(o)]
    if not top:
        raise InputError("%s: the document has no top-level object with a Part shape or a mesh" % path)
    if len(top) == 1:
        return top[0], "the document's only shape-bearing top-level object"
    visible = [o for o in top if getattr(o, "Visibility", True)]
    if len(visible) == 1:
        return visible[0], "the only visible one of %d shape-bearing top-level objects (%s)" % (len(top), _describe(top))
    raise InputError("%s: the document has %d shape-bearing top-level objects: %s; name one with --object"
                     % (path, len(top), _describe(top)))


@contextmanager
def document_object(path, object_name=None):
    """(object, input record) of the FreeCAD document at path while it is open: the record
    has the document's path and sha256, the object's name, label and type, and how it was
    chosen (pick_object)."""
    path = os.path.abspath(os.fspath(path))
    digest = sha256_file(path)
    with open_document(path) as doc:
        obj, how = pick_object(doc, path, object_name)
        yield obj, {"path": path, "sha256": digest, "format": "fcstd", "object": obj.Name, "label": obj.Label,
                    "object_type": obj.TypeId, "object_choice": how}
