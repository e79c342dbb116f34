"""Input files: format from the extension, representation, content hash."""
import functools
import hashlib
import os
import threading

from .errors import InputError
from .file_checks import check_file

MESH_FORMATS = {".stl": "stl", ".obj": "obj", ".ply": "ply"}
BREP_FORMATS = {".igs": "iges", ".iges": "iges", ".step": "step", ".stp": "step", ".brep": "brep"}
#: FreeCAD documents: one of their objects is assessed (document_input).
DOCUMENT_FORMATS = {".fcstd": "fcstd"}


def sha256_file(path):
    """Hex SHA-256 of the file's bytes, computed once for the same path, size and
    modification time (the input record asks for it before the reader and again in it),
    on the thread start_sha256 began for it, if any."""
    return start_sha256(path).result()


def start_sha256(path):
    """Begin the SHA-256 of the file on a thread of its own, which ends when the digest is
    made (hashlib lets go of the interpreter while it digests, so reading and hashing run
    side by side; once the digest is taken, no thread of it is left, so the process may
    fork). Returns the Digest, shared by the calls for the same path, size and
    modification time."""
    st = os.stat(path)
    key = (os.path.abspath(path), st.st_size, st.st_mtime_ns)
    with _DIGESTS_LOCK:
        digest = _DIGESTS.pop(key, None) or Digest(key[0])
        _DIGESTS[key] = digest
        while len(_DIGESTS) > MAX_DIGESTS:
            _DIGESTS.pop(next(iter(_DIGESTS)))
    return digest


class Digest:
    """The SHA-256 of one file, computed on a thread started at construction."""

    def __init__(self, path):
        self._value = self._error = None
        self._thread = threading.Thread(target=self._run, args=(path,), name="hullprod-sha256", daemon=True)
        self._thread.start()

    def _run(self, path, chunk=1 << 20):
        try:
            h = hashlib.sha256()
            with open(path, "rb") as fh:
                for block in iter(lambda: fh.read(chunk), b""):
                    h.update(block)
            self._value = h.hexdigest()
        except BaseException as exc:  # raised again to the caller of result()
            self._error = exc

    def result(self):
        """The hex digest, once the thread has ended (its error, if it had one)."""
        self._thread.join()
        if self._error is not None:
            raise self._error
        return self._value


#: Digests kept (the most recent files).
MAX_DIGESTS = 64
_DIGESTS = {}
_DIGESTS_LOCK = threading.Lock()


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
    size = os.path.getsize(path)
    declared = checked_structure(path, fmt, size, os.path.getmtime(path))
    info = {"path": path, "sha256": sha256_file(path), "format": fmt, "representation": rep, "size_bytes": size}
    if declared:
        info["declared"] = dict(declared)
    return info


def file_representation(path):
    """'mesh', 'brep' or 'document': the representation of a file that passes
    describe_file's checks, without its hash (the mesh path digests it beside its reading)."""
    path, fmt, rep = checked_path(path)
    checked_structure(path, fmt, os.path.getsize(path), os.path.getmtime(path))
    return rep


@functools.lru_cache(maxsize=64)
def checked_structure(path, fmt, size, mtime):
    """file_checks.check_file of path, once for the same path, size and modification time
    (describe_file is called before the reader and again by it)."""
    return check_file(path, fmt)
