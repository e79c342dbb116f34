"""Input files: format from the extension, representation, content hash."""
import functools
import hashlib
import os
import threading
from concurrent.futures import ThreadPoolExecutor

from .errors import InputError
from .file_checks import check_file

MESH_FORMATS = {".stl": "stl", ".obj": "obj", ".ply": "ply"}
BREP_FORMATS = {".igs": "iges", ".iges": "iges", ".step": "step", ".stp": "step", ".brep": "brep"}
#: FreeCAD documents: one of their objects is assessed (document_input).
DOCUMENT_FORMATS = {".fcstd": "fcstd"}


def sha256_file(path):
    """Hex SHA-256 of the file's bytes, computed once for the same path, size and
    modification time (the input record asks for it before the reader and again in it),
    in the background when start_sha256 began it."""
    return start_sha256(path).result()


def start_sha256(path):
    """Begin the SHA-256 of the file on a background thread (hashlib lets go of the
    interpreter while it digests, so reading and hashing run side by side); a
    concurrent.futures.Future of the hex digest, shared by the calls for the same path,
    size and modification time."""
    st = os.stat(path)
    key = (os.path.abspath(path), st.st_size, st.st_mtime_ns)
    with _HASHES_LOCK:
        future = _HASHES.pop(key, None)
        if future is None:
            future = _hash_pool().submit(_sha256, key[0])
        _HASHES[key] = future
        while len(_HASHES) > MAX_HASHES:
            _HASHES.pop(next(iter(_HASHES)))
    return future


#: Digests kept (the most recent files).
MAX_HASHES = 64
_HASHES = {}
_HASHES_LOCK = threading.Lock()


@functools.lru_cache(maxsize=None)
def _hash_pool():
    return ThreadPoolExecutor(max_workers=1, thread_name_prefix="hullprod-sha256")


def _sha256(path, chunk=1 << 20):
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(chunk), b""):
            h.update(block)
    return h.hexdigest()


def checked_path(path, representation=None):
    """(absolute path, format, representation) of a readable, non-empty file of a known
    format; representation ('mesh', 'brep', 'document') restricts the formats accepted."""
    kind = representation + " " if representation else ""
    if not isinstance(path, (str, os.PathLike)):
        raise InputError("expected a %sfile path, got %r" % (kind, path))
    path = os.fspath(path)
    if not os.path.exists(path):
        raise InputError("%s file not found: %s" % (representation or "input", path))
    if not os.path.isfile(path):
        raise InputError("%s input is not a file: %s" % (representation or "the", path))
    ext = os.path.splitext(path)[1].lower()
    tables = [(MESH_FORMATS, "mesh"), (BREP_FORMATS, "brep"), (DOCUMENT_FORMATS, "document")]
    tables = [t for t in tables if representation in (None, t[1])]
    for formats, rep in tables:
        if ext in formats:
            break
    else:
        known = sorted(set().union(*(f for f, _ in tables)))
        known = [".FCStd" if k == ".fcstd" else k for k in known]
        raise InputError("unknown %s format '%s' for %s (known: %s)" % (
            representation or "input", ext or "no extension", path, ", ".join(known)))
    if os.path.getsize(path) == 0:
        raise InputError("%s file is empty: %s" % (representation or "input", path))
    return os.path.abspath(path), formats[ext], rep


def describe_file(path):
    """Check that path is a readable, non-empty file of a known format (checked_path) whose
    structure is whole (file_checks.check_file: an InputError naming what is missing, before
    any reader sees the file).

    Returns dict(path, sha256, format, representation, size_bytes, and declared: what the
    file declares, e.g. declared_faces, when its format declares it).
    """
    path, fmt, rep = checked_path(path)
    start_sha256(path)
    size = os.path.getsize(path)
    declared = checked_structure(path, fmt, size, os.path.getmtime(path))
    info = {"path": path, "sha256": sha256_file(path), "format": fmt, "representation": rep, "size_bytes": size}
    if declared:
        info["declared"] = dict(declared)
    return info


def file_representation(path):
    """'mesh', 'brep' or 'document': the representation of a file that passes
    describe_file's checks, its SHA-256 begun in the background (start_sha256)."""
    path, fmt, rep = checked_path(path)
    start_sha256(path)
    checked_structure(path, fmt, os.path.getsize(path), os.path.getmtime(path))
    return rep


@functools.lru_cache(maxsize=64)
def checked_structure(path, fmt, size, mtime):
    """file_checks.check_file of path, once for the same path, size and modification time
    (describe_file is called before the reader and again by it)."""
    return check_file(path, fmt)
