"""BRep input: files, Part shapes and FreeCAD objects -> the faces to assess.

Files go through FreeCAD's Part/Import (OpenCascade converts lengths to millimetres), in
a child process (reader_process): OpenCascade's readers end the process on some damaged
files, and the child's end is reported (ReaderDied) instead. The child sends the shape
back as OpenCascade's binary BRep data (shape_to_bytes), read here by OpenCascade's own
binary reader. The geometry is never healed, sewn or tessellated for integration; the
caller's shape is never modified (we work on a copy).
"""
import os
import re
from dataclasses import dataclass, field
from typing import Optional

from ...core.errors import InputError
from ...core.inputs import describe_file
from ...freecad_env import import_freecad

#: IGES global-section unit flags (parameter 14) -> unit name.
IGES_UNIT_FLAGS = {1: "inch", 2: "mm", 3: None, 4: "ft", 5: "mile", 6: "m", 7: "km", 8: "mil",
                   9: "micron", 10: "cm", 11: "microinch"}


@dataclass
class BRepInput:
    """The shape to assess and what is known of where it came from.

    shape: Part.Shape (a copy); faces: list of (number, Part.Face) with FreeCAD's 1-based
    Face numbering of the whole shape; info: input dict for the JSON document; units:
    declared source unit and working unit; read_seconds: time taken to read it, and
    lref_tessellation: its automatic-L_ref tessellation when already started
    (lref_samples.read_and_start).
    """

    shape: object
    faces: list
    info: dict
    units: dict = field(default_factory=dict)
    read_seconds: Optional[float] = None
    lref_tessellation: object = None


def declared_unit(path, fmt):
    """Length unit declared in an IGES global section or a STEP file, or None."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(1 << 20).decode("latin-1")
    except OSError:
        return None
    if fmt == "iges":
        glob_text = "".join(line[:72] for line in head.splitlines() if len(line) >= 73 and line[72] == "G")
        if not glob_text:
            return None
        pdelim, rdelim = ",", ";"
        m = re.match(r"\s*1H(.)", glob_text)
        if m:
            pdelim = m.group(1)
        params, i, cur = [], 0, ""
        while i < len(glob_text) and len(params) < 16:
            h = re.match(r"(\d+)H", glob_text[i:])
            if h and cur.strip() == "":
                n = int(h.group(1))
                start = i + len(h.group(0))
                cur = glob_text[start:start + n]
                i = start + n
                continue
            ch = glob_text[i]
            if ch in (pdelim, rdelim):
                params.append(cur.strip())
                cur = ""
                if ch == rdelim:
                    break
            else:
                cur += ch
            i += 1
        try:
            flag = int(float(params[13]))
        except (IndexError, ValueError):
            return None
        return IGES_UNIT_FLAGS.get(flag) or (params[14] if len(params) > 14 else None)
    if fmt == "step":
        up = head.upper()
        if "CONVERSION_BASED_UNIT('INCH'" in up.replace(" ", ""):
            return "inch"
        m = re.search(r"SI_UNIT\s*\(\s*\.?([A-Z]*)\.?\s*,\s*\.METRE\.\s*\)", up)
        if m:
            prefix = m.group(1)
            return {"MILLI": "mm", "CENTI": "cm", "KILO": "km", "": "m", "$": "m"}.get(prefix, prefix.lower() + "m")
        if re.search(r"SI_UNIT\s*\(\s*\$\s*,\s*\.METRE\.\s*\)", up):
            return "m"
    return None


def _shape_of(source):
    """Part.Shape from a Part.Shape or a FreeCAD object with a Shape, copied."""
    import_freecad()
    import Part
    if isinstance(source, Part.Shape):
        shape = source
        name = "Part.Shape"
    elif hasattr(source, "Shape"):
        shape = source.Shape
        name = getattr(source, "Label", getattr(source, "Name", "object"))
    else:
        raise InputError("object of type %s has no Part shape" % type(source).__name__)
    if shape is None or shape.isNull():
        raise InputError("%s has an empty (null) shape" % name)
    return shape.copy(), name


def read_shape(path, fmt):
    """Read a BRep file with FreeCAD's Part module; clear errors for unreadable files."""
    import_freecad()
    import Part
    shape = Part.Shape()
    try:
        if fmt == "brep":
            shape.importBrep(path)
        else:
            shape = Part.read(path)
    except Exception as exc:  # OCC raises Part.OCCError / RuntimeError / FreeCAD.Base.FreeCADError
        raise InputError("cannot read %s file %s: %s" % (fmt.upper(), path, " ".join(str(exc).split()) or
                                                         type(exc).__name__)) from None
    if shape.isNull():
        raise InputError("%s file %s contains no shape (corrupt or empty)" % (fmt.upper(), path))
    return shape


def _memory_file():
    """(file descriptor, path) of an anonymous in-memory file (Linux memfd), or of a
    temporary file elsewhere; the caller closes the descriptor (and removes a path)."""
    if hasattr(os, "memfd_create"):
        fd = os.memfd_create("hullprod-brep")
        return fd, "/proc/self/fd/%d" % fd, False
    import tempfile
    fd, path = tempfile.mkstemp(prefix="hullprod-", suffix=".brep.bin")
    return fd, path, True


def shape_to_bytes(shape):
    """OpenCascade's binary BRep data of shape (exact doubles; shape_from_bytes reads it)."""
    fd, path, remove = _memory_file()
    try:
        shape.exportBinary(path)
        with open(path, "rb") as fh:
            return fh.read()
    finally:
        os.close(fd)
        if remove:
            os.unlink(path)


def shape_from_bytes(data):
    """The Part.Shape that shape_to_bytes wrote (FreeCAD is loaded here for it)."""
    import_freecad()
    import Part
    fd, path, remove = _memory_file()
    try:
        with open(path, "wb") as fh:
            fh.write(data)
        shape = Part.Shape()
        shape.importBinary(path)
    finally:
        os.close(fd)
        if remove:
            os.unlink(path)
    return shape


def faces_to_bytes(faces):
    """Part.Face list -> OpenCascade's binary BRep data of their compound (shape_to_bytes:
    the faces' orientations and locations as they are)."""
    import Part
    return shape_to_bytes(Part.Compound(list(faces)))


def faces_from_bytes(data):
    """The Part.Face list faces_to_bytes wrote, in its order (FreeCAD is loaded here for it)."""
    return list(shape_from_bytes(data).Faces)


def shape_frames(path, fmt):
    """In a reading process (reader_process): the one frame {"shape": shape_to_bytes} of
    the file read with read_shape."""
    import_freecad()
    yield {"shape": shape_to_bytes(read_shape(path, fmt))}


def read_shape_in_child(path, fmt):
    """read_shape(path, fmt) run in a reading process (reader_process.ReaderProcess), the
    shape rebuilt here from its binary BRep data; ReaderDied when the process dies."""
    from .reader_process import ReaderProcess
    child = ReaderProcess(path, (__name__, "shape_frames"), (path, fmt))
    try:
        return shape_from_bytes(child.receive(last=True)["shape"])
    finally:
        child.close()


def load_brep(source, faces=None, here=False):
    """Resolve source (path, Part.Shape or FreeCAD object) and the face selection.

    faces: 1-based FreeCAD face numbers (Face1 = 1) or None for all faces. A file is read
    in a reading process (read_shape_in_child), or with here=True in this one (a reading
    process itself).
    """
    if isinstance(source, (str, os.PathLike)):
        info = describe_file(source)
        if info["representation"] != "brep":
            raise InputError("%s is a triangle mesh, not a BRep" % source)
        shape = (read_shape if here else read_shape_in_child)(info["path"], info["format"])
        unit = declared_unit(info["path"], info["format"])
        units = {"source_unit": unit or ("mm" if info["format"] == "brep" else "undeclared"),
                 "working_unit": "mm" if info["format"] in ("iges", "step") else (unit or "model units"),
                 "note": "OpenCascade converts IGES/STEP lengths to millimetres on import"}
    else:
        shape, name = _shape_of(source)
        info = {"path": None, "name": name, "sha256": None, "format": "freecad-shape",
                "representation": "brep"}
        units = {"source_unit": "model units", "working_unit": "model units (FreeCAD: mm)"}
    all_faces = shape.Faces
    if not all_faces:
        raise InputError("the shape has no faces to assess (%s)" % (info.get("path") or info.get("name")))
    if faces is None:
        chosen = list(range(1, len(all_faces) + 1))
    else:
        chosen = sorted(set(int(f) for f in faces))
        bad = [f for f in chosen if not 1 <= f <= len(all_faces)]
        if bad:
            raise InputError("face number(s) %s out of range: the shape has faces 1..%d"
                             % (",".join(map(str, bad)), len(all_faces)))
    info["faces_used"] = chosen
    info["face_count"] = len(all_faces)
    return BRepInput(shape, [(n, all_faces[n - 1]) for n in chosen], info, units)
