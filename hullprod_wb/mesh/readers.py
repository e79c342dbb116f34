"""Mesh file readers straight into numpy arrays: binary STL and binary PLY as structured
dtypes read from the file, OBJ with a vectorised tokenizer; ASCII STL, ASCII PLY and every
layout the fast readers do not take (polygons, texture or normal indices, groups, extra
list properties) go to trimesh's readers, which define what such files mean here.

Every reader returns a :class:`RawMesh` whose vertices and faces are the ones trimesh's
reader gives for the same file (same values, same order), without trimesh's processing,
scene or cache work. :func:`header_counts` gives the vertex and face counts a file claims
(from its header, or estimated from its size for OBJ) before anything is read, for the
memory estimate of :mod:`.memory`.
"""
import logging
import os
from dataclasses import dataclass

import numpy as np

from ..core.errors import InputError

#: Binary STL: 80-byte header, uint32 triangle count, then 50-byte records.
STL_HEADER = 84
STL_RECORD = np.dtype([("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])

PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
             "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
             "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}
PLY_FACE_LISTS = ("vertex_indices", "vertex_index")


@dataclass
class RawMesh:
    """A file's triangles before preparation.

    vertices: (k, 3) float32 or float64 as stored; faces: (m, 3) int vertex ids, or None
    for a triangle soup, whose vertices are the corners: (m, 3, 3) (binary STL: a view of
    the mapped file) or (3m, 3) (triangle i = rows 3i..3i+2).
    """

    vertices: np.ndarray
    faces: object = None

    @property
    def n_faces(self):
        if self.faces is not None:
            return len(self.faces)
        return len(self.vertices) if self.vertices.ndim == 3 else len(self.vertices) // 3


def _binary_stl_count(path, size):
    """Triangle count of a binary STL (its size is exactly 84 + 50 count), else None (ASCII)."""
    if size < STL_HEADER:
        return None
    with open(path, "rb") as fh:
        fh.seek(80)
        count = int(np.frombuffer(fh.read(4), "<u4")[0])
    return count if size == STL_HEADER + STL_RECORD.itemsize * count else None


def read_stl(path):
    """Binary STL as a structured view of the mapped file; ASCII STL through trimesh."""
    size = os.path.getsize(path)
    count = _binary_stl_count(path, size)
    if count is None:
        return _trimesh_reader(path, "stl")
    if count == 0:
        raise InputError("mesh file %s has no triangles (empty mesh)" % path)
    records = np.memmap(path, dtype=STL_RECORD, mode="r", offset=STL_HEADER, shape=(count,))
    return RawMesh(records["corners"])


def _ply_header(fh):
    """(format, [(element, count, [(property, type or ('list', count type, item type))])],
    data offset) of a PLY file, or None if the header is not one this reader takes."""
    if fh.readline().strip() != b"ply":
        return None
    fmt, elements = None, []
    while True:
        line = fh.readline()
        if not line:
            return None
        words = line.decode("latin-1").split()
        if not words or words[0] in ("comment", "obj_info"):
            continue
        if words[0] == "end_header":
            break
        if words[0] == "format" and len(words) == 3:
            fmt = words[1]
        elif words[0] == "element" and len(words) == 3:
            elements.append((words[1], int(words[2]), []))
        elif words[0] == "property" and elements and len(words) == 3 and words[1] in PLY_TYPES:
            elements[-1][2].append((words[2], PLY_TYPES[words[1]]))
        elif (words[0] == "property" and elements and len(words) == 5 and words[1] == "list"
              and words[2] in PLY_TYPES and words[3] in PLY_TYPES):
            elements[-1][2].append((words[4], ("list", PLY_TYPES[words[2]], PLY_TYPES[words[3]])))
        else:
            return None
    return fmt, elements, fh.tell()


def _ply_counts(path):
    with open(path, "rb") as fh:
        header = _ply_header(fh)
    if header is None:
        return None
    counts = {name: count for name, count, _ in header[1]}
    return counts.get("vertex"), counts.get("face")


def read_ply(path):
    """Binary PLY of triangles (a vertex element with scalar x, y, z and a face element
    holding only a vertex index list) as two structured reads; anything else through trimesh."""
    with open(path, "rb") as fh:
        header = _ply_header(fh)
    fast = None
    if header is not None and header[0] in ("binary_little_endian", "binary_big_endian"):
        fast = _binary_ply_layout(header)
    if fast is None:
        return _trimesh_reader(path, "ply")
    (vdtype, nv), (fdtype, nf), offset, expected = fast
    if os.path.getsize(path) != expected:
        return _trimesh_reader(path, "ply")   # not all triangles, or a damaged file
    verts = np.fromfile(path, dtype=vdtype, count=nv, offset=offset)
    faces = np.fromfile(path, dtype=fdtype, count=nf, offset=offset + vdtype.itemsize * nv)
    if nf == 0 or nv == 0:
        raise InputError("mesh file %s has no triangles (empty mesh)" % path)
    if not np.all(faces["n"] == 3):
        return _trimesh_reader(path, "ply")   # polygons: trimesh triangulates them
    V = np.empty((nv, 3), dtype=np.result_type(*(vdtype[c] for c in "xyz")))
    for j, c in enumerate("xyz"):
        V[:, j] = verts[c]
    return RawMesh(V, faces["i"].astype(np.int64))


def _binary_ply_layout(header):
    fmt, elements, offset = header
    if [e[0] for e in elements] != ["vertex", "face"]:
        return None
    end = "<" if fmt == "binary_little_endian" else ">"
    (_, nv, vprops), (_, nf, fprops) = elements
    if any(isinstance(t, tuple) for _, t in vprops) or not {"x", "y", "z"} <= {p for p, _ in vprops}:
        return None
    if len(vprops) != len({p for p, _ in vprops}):
        return None
    if len(fprops) != 1 or fprops[0][0] not in PLY_FACE_LISTS or not isinstance(fprops[0][1], tuple):
        return None
    _, ctype, itype = fprops[0][1]
    if itype[0] == "f":
        return None
    vdtype = np.dtype([(p, end + t) for p, t in vprops])
    fdtype = np.dtype([("n", end + ctype), ("i", end + itype, (3,))])
    expected = offset + vdtype.itemsize * nv + fdtype.itemsize * nf
    return (vdtype, nv), (fdtype, nf), offset, expected


#: Bytes an OBJ of the simple layout may hold once its comment lines are dropped.
_OBJ_BYTES = b" \t\r\n0123456789eE+-.vf"
#: The keyword letters turned into spaces, which leaves the numbers.
_KEYWORDS_TO_SPACE = bytes.maketrans(b"vf", b"  ")
#: More comment lines than this: trimesh's reader.
MAX_OBJ_COMMENTS = 10000


def read_obj(path):
    """OBJ of vertex lines 'v x y z', triangle lines 'f a b c' (positive indices), comments
    and blank lines, parsed as whole blocks; anything else through trimesh. As trimesh's
    reader, only the vertices the faces use are kept, in file order."""
    with open(path, "rb") as fh:
        data = fh.read()
    parsed = _simple_obj(data)
    if parsed is None:
        return _trimesh_reader(path, "obj")
    V, F = parsed
    if len(F) == 0:
        raise InputError("mesh file %s has no triangles (empty mesh)" % path)
    if F.min() < 0 or F.max() >= len(V):
        return _trimesh_reader(path, "obj")
    used = np.zeros(len(V), dtype=bool)
    used[F] = True
    if not used.all():
        remap = np.cumsum(used) - 1
        V, F = V[used], remap[F]
    return RawMesh(V, F)


def _drop_comment_lines(data):
    """data without its comment lines ('#' first on a line), or None (a '#' elsewhere, or
    very many comments)."""
    cuts, pos = [], data.find(b"#")
    while pos >= 0:
        if pos > 0 and data[pos - 1] != ord("\n") or len(cuts) > MAX_OBJ_COMMENTS:
            return None
        end = data.find(b"\n", pos)
        end = len(data) if end < 0 else end
        cuts.append((pos, end))
        pos = data.find(b"#", end)
    view, parts, last = memoryview(data), [], 0
    for a, b in cuts:
        parts.append(view[last:a])
        last = b
    parts.append(view[last:])
    return b"".join(parts)      # one copy: the parts are views


def _simple_obj(data):
    """(vertices (k, 3) float64, faces (m, 3) int64, 0-based) of an OBJ made only of v, f,
    comment and blank lines with three values each, or None.

    Every line must be blank or a one-letter keyword followed by exactly three tokens.
    A token starts at a non-space byte after a space; the starts, taken four at a time,
    must begin at the keyword lines' starts and end before their ends (which leaves no
    token for any other line). The numbers of each block of lines of one kind are then
    parsed at once."""
    if b"#" in data:
        data = _drop_comment_lines(data)
        if data is None:
            return None
    if not data or data.translate(None, _OBJ_BYTES):
        return None
    buf = np.frombuffer(data, dtype=np.uint8)
    space = buf <= 32
    start = ~space
    start[1:] &= space[:-1]
    line_start = np.concatenate([[0], np.flatnonzero(buf == ord("\n")) + 1])
    line_start = line_start[line_start < len(buf)]
    head = buf[line_start]
    second = buf[np.minimum(line_start + 1, len(buf) - 1)]
    keyword = ((head == ord("v")) | (head == ord("f"))) & (second <= 32) & (line_start + 1 < len(buf))
    lines = np.flatnonzero(keyword)
    tokens = np.flatnonzero(start)
    del space, start
    if len(lines) == 0 or len(tokens) != 4 * len(lines):
        return None
    tokens = tokens.reshape(-1, 4)
    line_end = np.append(line_start[1:], len(buf))[lines]
    if not (np.array_equal(tokens[:, 0], line_start[lines]) and np.all(tokens[:, 3] < line_end)):
        return None
    del tokens, line_end
    is_face = head[lines] == ord("f")
    text = data.translate(_KEYWORDS_TO_SPACE)
    change = np.flatnonzero(is_face[1:] != is_face[:-1]) + 1
    bounds = np.concatenate([[0], change, [len(lines)]])
    vs, fs = [], []
    for a, b in zip(bounds[:-1], bounds[1:]):
        lo = line_start[lines[a]]
        hi = line_start[lines[b]] if b < len(lines) else len(buf)
        chunk = text[lo:hi]
        if is_face[a]:
            if any(c in chunk for c in (b".", b"e", b"E", b"+", b"-")):
                return None               # not positive integer indices
            vals, out = np.fromstring(chunk, dtype=np.int64, sep=" "), fs
        else:
            vals, out = np.fromstring(chunk, dtype=np.float64, sep=" "), vs
        if len(vals) != 3 * (b - a):
            return None
        out.append(vals.reshape(-1, 3))
    V = np.concatenate(vs) if vs else np.zeros((0, 3))
    F = np.concatenate(fs) - 1 if fs else np.zeros((0, 3), dtype=np.int64)
    return V, F


#: What a use of trimesh says where it is not installed (one line, how to install).
TRIMESH_MISSING = ("%s needs the Python package trimesh, which is not installed: install it into "
                   "FreeCAD's Python and restart FreeCAD (on Debian: /usr/bin/python3 -m pip install "
                   "--break-system-packages --no-deps 'trimesh>=4.4,<5'); binary STL and binary PLY "
                   "files of triangles are read without it")


def require_trimesh(what):
    """The trimesh package; InputError(TRIMESH_MISSING naming what) where it is not installed."""
    try:
        import trimesh
    except ImportError:
        raise InputError(TRIMESH_MISSING % what) from None
    return trimesh


class _ReaderLog(logging.Handler):
    """The records trimesh's loggers emit during one read. trimesh catches some parse errors
    itself and logs them with their traceback; such a record means the file holds data the
    reader could not parse."""

    def __init__(self):
        super().__init__(logging.WARNING)
        self.records = []

    def emit(self, record):
        self.records.append(record)

    def __enter__(self):
        self.logger = logging.getLogger("trimesh")
        self.logger.addHandler(self)
        self.propagate, self.logger.propagate = self.logger.propagate, False
        return self

    def __exit__(self, *exc):
        self.logger.removeHandler(self)
        self.logger.propagate = self.propagate

    def parse_error(self):
        """'message (ExceptionType: text)' of the first record with an exception, or None."""
        for r in self.records:
            if r.exc_info and r.exc_info[1] is not None:
                e = r.exc_info[1]
                return "%s (%s: %s)" % (r.getMessage(), type(e).__name__, " ".join(str(e).split()))
        return None

    def passed_on(self):
        """The other records, one line each, to this module's logger."""
        for r in self.records:
            if not r.exc_info:
                logging.getLogger(__name__).warning("trimesh: %s", r.getMessage())


def _trimesh_reader(path, fmt):
    """The file through trimesh's reader of fmt (no processing, no scene): RawMesh. Any error of
    the reader, raised or caught and logged by trimesh, is InputError (a damaged file)."""
    trimesh = require_trimesh("reading %s files" % ("ASCII STL" if fmt == "stl" else "this kind of " + fmt.upper()))
    try:
        with _ReaderLog() as log:
            if fmt == "stl":
                from trimesh.exchange.stl import load_stl
                with open(path, "rb") as fh:
                    kw = load_stl(fh)
                vertices, faces = kw["vertices"], kw["faces"]
            else:
                loaded = trimesh.load(path, file_type=fmt, force="mesh", process=False)
                if not isinstance(loaded, trimesh.Trimesh):
                    raise InputError("mesh file %s holds no triangle mesh" % path)
                vertices, faces = loaded.vertices, loaded.faces
    except InputError:
        raise
    except Exception as exc:  # the readers raise many kinds of errors for unreadable files
        raise InputError("cannot read mesh file %s as %s: %s" % (path, fmt.upper(), exc)) from None
    error = log.parse_error()
    if error is not None:
        raise InputError("cannot read mesh file %s as %s: %s" % (path, fmt.upper(), error))
    log.passed_on()
    return RawMesh(np.asarray(vertices), np.asarray(faces))


READERS = {"stl": read_stl, "ply": read_ply, "obj": read_obj}


def read_mesh_file(path, fmt):
    """RawMesh of a checked .stl/.ply/.obj path (see the module docstring)."""
    return READERS[fmt](path)


def header_counts(path, fmt):
    """(vertices, faces) a mesh file will give, from its header (binary STL, PLY) or its
    size (ASCII STL: about 250 bytes a triangle; OBJ: about 90 bytes a vertex, its line and
    two triangle lines), before it is read; a closed surface has two triangles a vertex."""
    size = os.path.getsize(path)
    if fmt == "stl":
        count = _binary_stl_count(path, size)
        faces = count if count is not None else size // 250
        return faces // 2 + 2, faces
    if fmt == "ply":
        counts = _ply_counts(path)
        if counts and counts[0] is not None and counts[1] is not None:
            return counts
    vertices = size // 90
    return vertices, 2 * vertices
