"""What the user selected -> sources to analyse (no GUI types: plain objects and names)."""
import re

from ..core.errors import InputError

_FACE = re.compile(r"^Face(\d+)$")


def faces_from_subelements(names):
    """FreeCAD sub-element names -> sorted 1-based face numbers ('Face3' -> 3).

    Other sub-elements (edges, vertices) are ignored; None when no face was named.
    """
    faces = sorted({int(m.group(1)) for m in (_FACE.match(str(n).split(".")[-1]) for n in names or ()) if m})
    return faces or None


def ignored_subelements(names):
    """Sub-element names that are not faces (edges, vertices): they select nothing to assess."""
    return [str(n) for n in names or () if not _FACE.match(str(n).split(".")[-1])]


def sources_from_selection(selection):
    """[(object, faces or None)] from (object, sub-element names) pairs.

    Part objects keep only their selected faces; Mesh objects are analysed whole;
    analyses and objects without a shape or mesh are skipped. The same object selected
    twice is merged (union of faces; whole object if selected whole once).
    """
    from .analysis import is_analysis
    order, merged, faceless = [], {}, []
    for obj, subs in selection:
        if obj is None or is_analysis(obj) or not (hasattr(obj, "Shape") or hasattr(obj, "Mesh")):
            continue
        if hasattr(obj, "Shape") and not hasattr(obj, "Mesh") and not _has_faces(obj):
            faceless.append(obj.Label)
            continue
        faces = faces_from_subelements(subs) if hasattr(obj, "Shape") else None
        if obj.Name not in merged:
            order.append(obj)
            merged[obj.Name] = faces
        elif merged[obj.Name] is not None:
            merged[obj.Name] = None if faces is None else sorted(set(merged[obj.Name]) | set(faces))
    if not order and faceless:
        raise InputError("%s has no faces (a sketch, wire or line): select a Part object with surfaces, "
                         "faces of a Part, or a Mesh object" % ", ".join(faceless))
    if not order:
        raise InputError("select one or more Part objects, faces of a Part, or Mesh objects to analyse")
    return [(o, merged[o.Name]) for o in order]


def _has_faces(obj):
    shape = getattr(obj, "Shape", None)
    try:
        return shape is not None and not shape.isNull() and len(shape.Faces) > 0
    except Exception:  # an invalid shape: let the assessment say why
        return True


def analyses_from_selection(objects):
    """The HullProd analyses among the selected objects (their display is the analysis itself)."""
    from .analysis import is_analysis
    return [o for o in objects if is_analysis(o)]
