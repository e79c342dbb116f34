"""Input files: format from the extension, representation, content hash."""
import functools
import hashlib
import os

from .errors import InputError
from .file_checks import check_file

MESH_FORMATS = {".stl": "stl", ".obj": "obj", ".ply": "ply"}
BREP_FORMATS = {".igs": "iges", ".iges": "iges", ".step": "step", ".stp": "step", ".brep": "brep"}
#: FreeCAD documents: one of their objects is assessed (document_input).
DOCUMENT_FORMATS = {".fcstd": "fcstd"}


def sha256_file(path):
    """Hex SHA-256 of the file's bytes, computed once for the same path, size and
    modification time (the input record asks for it before the reader and again in it)."""
    st = os.stat(path)
    return _sha256(os.path.abspath(path), st.st_size, st.st_mtime_ns)


@functools.lru_cache(maxsize=64)
def _sha256(path, size, mtime_ns, chunk=1 << 20):
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(chunk), b""):
            h.update(block)
    return h.hexdigest()


def describe_file(path):
    """Check that path is a readable, non-empty file of a known format whose structure is
    whole (file_checks.check_file: an InputError naming what is missing, before any reader
    sees the file).

    Returns dict(path, sha256, format, representation, size_bytes, and declared: what the
    file declares, e.g. declared_faces, when its format declares it).
    """
    if not isinstance(path, (str, os.PathLike)):
        raise InputError("expected a file path, got %r" % (path,))
    path = os.fspath(path)
    if not os.path.exists(path):
        raise InputError("input file not found: %s" % path)
    if not os.path.isfile(path):
        raise InputError("input is not a file: %s" % path)
    ext = os.path.splitext(path)[1].lower()
    if ext in MESH_FORMATS:
        fmt, rep = MESH_FORMATS[ext], "mesh"
    elif ext in BREP_FORMATS:
        fmt, rep = BREP_FORMATS[ext], "brep"
    elif ext in DOCUMENT_FORMATS:
        fmt, rep = DOCUMENT_FORMATS[ext], "document"
    else:
        known = ", ".join(sorted(set(MESH_FORMATS) | set(BREP_FORMATS)) + [".FCStd"])
        raise InputError("unknown input format '%s' for %s (known: %s)" % (ext or "no extension", path, known))
    size = os.path.getsize(path)
    if size == 0:
        raise InputError("input file is empty: %s" % path)
    info = {"path": os.path.abspath(path), "sha256": sha256_file(path), "format": fmt,
            "representation": rep, "size_bytes": size}
    declared = checked_structure(info["path"], fmt, size, os.path.getmtime(path))
    if declared:
        info["declared"] = dict(declared)
    return info


@functools.lru_cache(maxsize=64)
def checked_structure(path, fmt, size, mtime):
    """file_checks.check_file of path, once for the same path, size and modification time
    (describe_file is called before the reader and again by it)."""
    return check_file(path, fmt)
