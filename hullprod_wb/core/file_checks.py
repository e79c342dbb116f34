"""Structural checks of an input file before any reader sees it: cheap, exact, plain Python.

A file that is cut short or whose structure is broken is refused with one line that names
what is missing (InputError), instead of being handed to a reader that may read part of
it, or end the process. What each format declares and what is checked:

- IGES: 80-column records in the order S, G, D, P, T, each section numbered 1..n; the
  Terminate record's section counts against the lines present; an even number of
  directory-entry lines, the same entity type on both lines of an entry, its parameter
  pointer and line count inside the parameter section, and the entity type again at the
  start of its parameter data.
- STEP (ISO 10303-21): ISO-10303-21; first, HEADER; DATA; and their ENDSEC;, and
  END-ISO-10303-21; last.
- OpenCascade .brep (text): its CASCADE Topology header, the sections up to TShapes, the
  declared number of topological shapes present and the root shape's line last.
- STL: a binary file's 84 + 50 n bytes for its n declared triangles; an ASCII file's
  endsolid.
- PLY: the header's end, and the vertex and face elements it declares against the bytes
  (binary) or lines (ASCII) present.
- FreeCAD document (.FCStd): a whole zip archive with its Document.xml.

check_file also returns what the file declares that the reader's result can be compared
with: the number of faces (IGES: trimmed and bounded surfaces, faces and independent
untrimmed surfaces; STEP: ADVANCED_FACE and FACE_SURFACE entities; .brep: Fa shapes).
"""
import mmap
import os
import re
import struct

from .errors import InputError

#: IGES untrimmed surface entity types (each independent one becomes a face when read).
IGES_SURFACE_TYPES = frozenset({108, 114, 118, 120, 122, 128, 140, 190, 192, 194, 196, 198})
#: IGES entity types that are faces, with the index of their surface pointer parameter.
IGES_FACE_TYPES = {144: 1, 143: 2, 510: 1}
#: The sections of an OpenCascade text .brep, in order (the first and last are required).
BREP_SECTIONS = ("Locations", "Curve2ds", "Curves", "Polygon3D", "PolygonOnTriangulations", "Surfaces",
                 "Triangulations", "TShapes")
BREP_SHAPE_CODES = frozenset({"Ve", "Ed", "Wi", "Fa", "Sh", "So", "CS", "Co"})
#: Records of a binary PLY list element checked in one slice at first (doubling while their
#: list counts agree).
LIST_RUN_WINDOW = 16
#: Bytes of PLY scalar property types.
PLY_SIZES = {"char": 1, "uchar": 1, "int8": 1, "uint8": 1, "short": 2, "ushort": 2, "int16": 2, "uint16": 2,
             "int": 4, "uint": 4, "int32": 4, "uint32": 4, "float": 4, "float32": 4, "double": 8, "float64": 8}
#: Formats whose checks read the whole file as text (the others map it and read what they look at).
READ_WHOLE = ("iges", "step", "brep", "fcstd")
IGES_SECTIONS = {"S": "Start", "G": "Global", "D": "Directory Entry", "P": "Parameter Data", "T": "Terminate"}


def _fail(path, text):
    raise InputError("%s: %s" % (text, path))


def _int(text):
    try:
        return int(text.strip())
    except ValueError:
        return None


# -- IGES -------------------------------------------------------------------------------------


def _iges_records(data):
    """The 80-column records of an IGES file (line ends dropped; a file without line ends
    is cut into 80-byte records)."""
    text = data.decode("latin-1")
    lines = text.splitlines()
    if len(lines) == 1 and len(lines[0]) > 81 and len(lines[0]) % 80 == 0:
        lines = [lines[0][i:i + 80] for i in range(0, len(lines[0]), 80)]
    while lines and not lines[-1].strip(" \x1a\x00"):
        lines.pop()
    if lines and len(lines[-1].rstrip("\x1a\x00")) < 80 and len(lines) > 1 and len(lines[-2]) >= 80:
        lines.pop()  # a last record cut short: the file ends before it (see the Terminate check)
    return lines


def check_iges(path, data):
    lines = _iges_records(data)
    if not lines:
        _fail(path, "not an IGES file (no records)")
    if len(lines[0]) >= 73 and lines[0][72] in "CB":
        return {}  # compressed or binary IGES: no fixed records to check
    sections = {k: [] for k in "SGDPT"}
    order, current = "SGDPT", 0
    for i, line in enumerate(lines, 1):
        letter = line[72:73]
        if letter not in sections:
            _fail(path, "not a valid IGES file: line %d has no section letter in column 73 (%r)"
                  % (i, line[72:80] if len(line) > 72 else line[-8:]))
        k = order.index(letter)
        if k < current:
            _fail(path, "not a valid IGES file: line %d is a %s line after the %s section"
                  % (i, IGES_SECTIONS[letter], IGES_SECTIONS[order[current]]))
        current = k
        sections[letter].append(line)
    first = 1
    for letter in order:  # each section numbered 1..n: its last line's number is its count
        sec = sections[letter]
        if sec and _int(sec[-1][73:80]) != len(sec):
            _fail(path, "damaged IGES file: line %d is numbered %s in the %s section, expected %d (a line is "
                  "missing, repeated or overwritten)" % (first + len(sec) - 1, sec[-1][73:80].strip() or "blank",
                                                          IGES_SECTIONS[letter], len(sec)))
        first += len(sec)
    n_d, n_p = len(sections["D"]), len(sections["P"])
    entries, problem = _iges_entries(sections["D"], n_p)
    declared_p = max((p + c - 1 for _, p, c, _ in entries), default=0)
    if not sections["T"]:
        where = next(IGES_SECTIONS[s] for s in reversed(order) if sections[s])
        text = "truncated: the IGES Terminate section is missing (the file ends in its %s section)" % where
        if declared_p:
            text += "; %d of %d parameter lines present" % (n_p, declared_p)
        _fail(path, text)
    t = sections["T"][0]
    declared = {s: _int(t[8 * j + 1:8 * j + 8]) for j, s in enumerate("SGDP") if t[8 * j] == s}
    for s in "SGDP":
        if declared.get(s) is None:
            _fail(path, "damaged IGES file: the Terminate record has no %s section count (%r)" % (IGES_SECTIONS[s], t[:32]))
        if declared[s] != len(sections[s]):
            _fail(path, "%s: the IGES Terminate record declares %d %s lines, %d present"
                  % ("truncated" if declared[s] > len(sections[s]) else "damaged IGES file", declared[s],
                     IGES_SECTIONS[s], len(sections[s])))
    if n_d % 2:
        _fail(path, "damaged IGES file: %d directory-entry lines (two a entry)" % n_d)
    if problem:
        _fail(path, "damaged IGES file: " + problem)
    pdelim = _iges_delimiter(sections["G"])
    params = "\n".join(p[:64] for p in sections["P"])
    _no_special_reals(path, "IGES", r"(?:^|[%s;])\s*[-+]?(?:nan|inf|infinity)\s*(?:[%s;]|$)"
                      % (re.escape(pdelim), re.escape(pdelim)), params, re.IGNORECASE | re.MULTILINE)
    problem, faces = _iges_parameters(entries, sections["P"], n_d, pdelim)
    if problem:
        _fail(path, "damaged IGES file: " + problem)
    return {"declared_faces": faces,
            "declared_faces_rule": "IGES trimmed (144) and bounded (143) surfaces, faces (510) and independent "
                                   "untrimmed surfaces not used by them"}


def _iges_entries(d_lines, n_p):
    """[(entity type, parameter pointer, parameter line count, status)] of the complete
    directory entries, and the first problem found (or None)."""
    out = []
    for k in range(0, len(d_lines) - 1, 2):
        a, b = d_lines[k], d_lines[k + 1]
        etype, etype2, ptr, count = _int(a[0:8]), _int(b[0:8]), _int(a[8:16]), _int(b[24:32])
        n = k // 2 + 1
        if etype is None or etype != etype2:
            return out, "directory entry %d (D lines %d-%d): entity type %r on one line, %r on the other" % (
                n, k + 1, k + 2, a[0:8].strip(), b[0:8].strip())
        if ptr is None or count is None or ptr < 1 or count < 1:
            return out, "directory entry %d (D line %d): parameter pointer %r, line count %r" % (
                n, k + 1, a[8:16].strip(), b[24:32].strip())
        out.append((etype, ptr, count, a[64:72]))
    for n, (etype, ptr, count, _) in enumerate(out, 1):
        if ptr + count - 1 > n_p:
            return out, ("directory entry %d (entity type %d) points to parameter lines %d-%d, of %d present"
                         % (n, etype, ptr, ptr + count - 1, n_p))
    return out, None


def _iges_delimiter(g_lines):
    """The parameter delimiter of the Global section (default ',')."""
    head = "".join(line[:72] for line in g_lines)[:8]
    m = re.match(r"\s*1H(.)", head)
    return m.group(1) if m else ","


def _iges_parameters(entries, p_lines, n_d, pdelim):
    """(first problem or None, declared faces) from the parameter data of the entries:
    each entry's data begins with its entity type and its lines point back to it."""
    surfaces, used, faces = set(), set(), 0
    for n, (etype, ptr, count, status) in enumerate(entries, 1):
        de = 2 * n - 1
        first = p_lines[ptr - 1]
        back = _int(first[64:72])
        if back != de:
            return ("parameter line %d (of directory entry %d) points back to D line %s, not %d"
                    % (ptr, n, first[64:72].strip() or "blank", de)), 0
        head = first[:64].split(pdelim, 1)[0].split(";", 1)[0]
        if _int(head) != etype:
            return ("directory entry %d declares entity type %d but its parameter data (line %d) begins with %r"
                    % (n, etype, ptr, head.strip())), 0
        if etype in IGES_FACE_TYPES:
            faces += 1
            params = "".join(p[:64] for p in p_lines[ptr - 1:ptr - 1 + count]).split(";", 1)[0].split(pdelim)
            k = IGES_FACE_TYPES[etype]
            if len(params) > k and _int(params[k]) is not None:
                used.add(_int(params[k]))
        elif etype in IGES_SURFACE_TYPES and status[2:4] in ("00", "  ", " 0", "0 "):
            surfaces.add(de)
    return None, faces + len(surfaces - used)


# -- STEP -------------------------------------------------------------------------------------


#: A positive decimal exponent of three digits or more (lower case): a magnitude of 1e100 or
#: more, which OpenCascade takes as infinite (Precision::Infinite, 2e100) and no hull's
#: geometry has; OpenCascade's readers can stall on such poles.
LONG_EXPONENT = re.compile(r"[\d.][ed]\+?0*[1-9]\d{2,}")


def _no_special_reals(path, kind, pattern, text, flags=0):
    """InputError when the regular expression pattern (a NaN or an infinity where the format
    has only finite reals; searched only when the text has 'nan' or 'inf') matches in text,
    or text has a number of 1e100 or more (LONG_EXPONENT)."""
    low = text.lower()
    match = re.search(pattern, text, flags) if ("nan" in low or "inf" in low) else None
    if match:
        line = text.count("\n", 0, match.start()) + 1
        _fail(path, "damaged %s file: %r where a number should be (line %d)"
              % (kind, " ".join(match.group(0).split()), line))
    match = LONG_EXPONENT.search(low)
    if match:
        line = text.count("\n", 0, match.start()) + 1
        _fail(path, "damaged %s file: a number of 1e100 or more (line %d), beyond any geometry "
              "(OpenCascade takes 2e100 as infinite)" % (kind, line))


def check_step(path, data):
    text = data.decode("latin-1")
    head = text.lstrip("\ufeff\xef\xbb\xbf \t\r\n")
    if not head.upper().startswith("ISO-10303-21;"):
        _fail(path, "not a STEP file: it does not begin with ISO-10303-21; (it begins %r)" % head[:20])
    tail = text.rstrip(" \t\r\n\x00\x1a")
    if not tail.upper().endswith("END-ISO-10303-21;"):
        _fail(path, "truncated: the STEP file does not end with END-ISO-10303-21; (its last bytes: %r)"
              % " ".join(tail[-30:].split()))
    up = text.upper()
    h, d = up.find("HEADER;"), up.find("DATA;")
    if h < 0 or d < 0 or d < h:
        _fail(path, "damaged STEP file: its %s section is missing" % ("HEADER" if h < 0 else "DATA"))
    sections = len(re.findall(r"(?:^|[\s;])DATA\s*(?:\([^)]*\))?\s*;", up)) + 1
    ends = len(re.findall(r"ENDSEC\s*;", up))
    if ends < sections:
        _fail(path, "truncated: the STEP file has %d sections (HEADER and DATA) and %d ENDSEC;" % (sections, ends))
    _no_special_reals(path, "STEP", r"[(,]\s*[-+]?(?:NAN|INF|INFINITY)\s*[),]", up)
    faces = len(re.findall(r"=\s*(?:ADVANCED_FACE|FACE_SURFACE)\s*\(", up))
    return {"declared_faces": faces, "declared_faces_rule": "STEP ADVANCED_FACE and FACE_SURFACE entities"}


# -- OpenCascade .brep --------------------------------------------------------------------------


def check_brep(path, data):
    text = data.decode("latin-1")
    lines = text.splitlines()
    first = next((i for i, line in enumerate(lines[:3]) if "CASCADE Topology V" in line), None)
    if first is None:
        if data[:64].find(b"CASCADE Topology V") >= 0:  # binary BRep (BinTools): no text sections
            return {}
        _fail(path, "not an OpenCascade BRep file: no 'CASCADE Topology V' header in its first lines")
    starts = {}
    for i, line in enumerate(lines):
        word = line.split(" ", 1)[0]
        if word in BREP_SECTIONS and word not in starts:
            parts = line.split()
            if len(parts) == 2 and _int(parts[1]) is not None:
                starts[word] = (i, int(parts[1]))
    missing = [s for s in BREP_SECTIONS if s not in starts]
    if missing:
        _fail(path, "truncated: the BRep file has no %s section (of %s)" % (missing[0], ", ".join(BREP_SECTIONS)))
    at = [starts[s][0] for s in BREP_SECTIONS]
    if at != sorted(at):
        _fail(path, "damaged BRep file: its sections are out of order")
    _no_special_reals(path, "BRep", r"(?:^|\s)[-+]?(?:nan|inf|infinity)(?:\s|$)", text, re.IGNORECASE)
    i0, n = starts["TShapes"]
    body = [line.strip() for line in lines[i0 + 1:]]
    codes = [c for c in body if c in BREP_SHAPE_CODES]
    if len(codes) < n:
        _fail(path, "truncated: the BRep file declares %d topological shapes, %d present" % (n, len(codes)))
    last = next((c for c in reversed(body) if c), "")
    if not re.fullmatch(r"[+\-*]\d+\s+\d+", last):
        _fail(path, "truncated: the BRep file does not end with its root shape (last line %r)" % last[:40])
    return {"declared_faces": codes.count("Fa"), "declared_faces_rule": "BRep Fa shapes"}


# -- meshes -----------------------------------------------------------------------------------


def _last_line(data):
    """The last line of data (bytes or a mapped file) once trailing blanks, NUL and ^Z bytes
    are dropped, stripped: read from the end, a few kB at a time."""
    end, chunk = len(data), 4096
    while end > 0:
        piece = data[max(0, end - chunk):end].rstrip(b" \t\r\n\x00\x1a")
        end = max(0, end - chunk) + len(piece)
        if piece:
            break
    return data[data.rfind(b"\n", 0, end) + 1:end].strip()


def check_stl(path, data):
    size = len(data)
    head = data[:512].lstrip().lower()
    if size >= 84:
        n = struct.unpack("<I", data[80:84])[0]
        if 84 + 50 * n == size:
            return {"declared_triangles": n}
    if head.startswith(b"solid") and (b"facet" in head or b"endsolid" in head):
        tail = _last_line(data).lower()
        if not tail.startswith(b"endsolid"):
            _fail(path, "truncated: the ASCII STL file does not end with endsolid (last line %r)"
                  % tail[:40].decode("latin-1"))
        return {}
    if size < 84:
        _fail(path, "truncated: a binary STL has an 84-byte header, the file has %d bytes" % size)
    if 84 + 50 * n > size:
        _fail(path, "truncated: the binary STL declares %d triangles (%d bytes), the file has %d bytes"
              % (n, 84 + 50 * n, size))
    return {"declared_triangles": n}


def check_ply(path, data):
    end = data.find(b"end_header")
    if data[:3] != b"ply" or end < 0:
        _fail(path, "truncated: the PLY header has no end_header" if data[:3] == b"ply"
              else "not a PLY file: it does not begin with 'ply'")
    nl = data.find(b"\n", end)
    body_at = len(data) if nl < 0 else nl + 1
    fmt, elements = None, []
    for line in data[:end].decode("latin-1").splitlines():
        w = line.split()
        if not w:
            continue
        if w[0] == "format" and len(w) > 1:
            fmt = w[1]
        elif w[0] == "element" and len(w) == 3 and _int(w[2]) is not None:
            elements.append([w[1], int(w[2]), []])
        elif w[0] == "property" and elements:
            elements[-1][2].append(w[1:])
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        _fail(path, "damaged PLY file: unknown format %r" % fmt)
    counts = {name: n for name, n, _ in elements}
    if fmt == "ascii":
        rows = data[body_at:].split(b"\n")
        rows = [r for r in rows if r.strip()]
        needed = sum(n for _, n, _ in elements)
        if len(rows) < needed:
            _fail(path, "truncated: the PLY header declares %s, %d data lines present"
                  % (_declared(elements), len(rows)))
        return {"declared_elements": counts}
    order = "<" if fmt == "binary_little_endian" else ">"
    at = body_at
    for name, n, props in elements:
        at = _ply_binary_element(path, data, at, name, n, props, order, elements)
    return {"declared_elements": counts}


def _declared(elements):
    return ", ".join("%d %s" % (n, name) for name, n, _ in elements)


def _ply_binary_element(path, data, at, name, n, props, order, elements):
    """Offset after n binary records of element name (props: property declarations)."""
    size = len(data)
    if all(p[0] != "list" for p in props):
        try:
            rec = sum(PLY_SIZES[p[0]] for p in props)
        except KeyError as exc:
            _fail(path, "damaged PLY file: unknown property type %s" % exc)
        if at + n * rec > size:
            _fail(path, "truncated: the PLY header declares %s; %d of %d bytes of its %s present"
                  % (_declared(elements), max(size - at, 0), n * rec, name))
        return at + n * rec
    fixed = sum(PLY_SIZES.get(p[0], 0) for p in props if p[0] != "list")
    lists = [(PLY_SIZES.get(p[1]), PLY_SIZES.get(p[2])) for p in props if p[0] == "list" and len(p) >= 3]
    if len(lists) != 1 or None in lists[0]:
        return size  # several lists a record: not checked further
    csize, isize = lists[0]
    cfmt = order + {1: "B", 2: "H", 4: "I"}[csize]
    k, window = 0, LIST_RUN_WINDOW
    while k < n:  # fixed-size part assumed before the list (the usual vertex_indices)
        if at + fixed + csize > size:
            _fail(path, "truncated: the PLY header declares %s; the file ends in %s %d"
                  % (_declared(elements), name, k + 1))
        stride = fixed + csize + struct.unpack_from(cfmt, data, at + fixed)[0] * isize
        run = _same_count_run(data, at + fixed, csize, stride, min(n - k, window))
        at, k = at + run * stride, k + run
        window = 2 * window if run == window else max(LIST_RUN_WINDOW, 2 * run)
    if at > size:
        _fail(path, "truncated: the PLY header declares %s; the file ends in its last %s" % (_declared(elements), name))
    return at


def _same_count_run(data, at, csize, stride, most):
    """How many records of stride bytes from the list count at offset at (csize bytes) carry
    the same count as the first, up to most: each byte of the count read at that stride in
    one slice (bytes in C, not a record at a time); the records the file holds only."""
    head = data[at:at + csize]
    run = min(most, max(0, (len(data) - at - csize) // stride + 1))
    for b in range(csize):
        column = data[at + b:at + b + (run - 1) * stride + 1:stride]
        run = min(run, len(column) - len(column.lstrip(head[b:b + 1])))
    return max(run, 1)


def check_fcstd(path, data):
    import io
    import zipfile
    try:
        names = zipfile.ZipFile(io.BytesIO(data)).namelist()
    except zipfile.BadZipFile:
        _fail(path, "truncated or damaged: the FreeCAD document is not a whole zip archive")
    if "Document.xml" not in names:
        _fail(path, "damaged FreeCAD document: its archive has no Document.xml")
    return {}


CHECKS = {"fcstd": check_fcstd, "iges": check_iges, "step": check_step, "brep": check_brep, "stl": check_stl, "ply": check_ply}


def check_file(path, fmt):
    """Structural check of the file at path in format fmt (inputs.MESH_FORMATS and
    BREP_FORMATS' names): an InputError naming what is missing or broken, else a dict of
    what the file declares (declared_faces, declared_triangles, declared_elements; {} for
    a format without checks)."""
    check = CHECKS.get(fmt)
    if check is None:
        return {}
    try:
        with open(path, "rb") as fh:
            if fmt in READ_WHOLE or os.fstat(fh.fileno()).st_size == 0:
                data = fh.read()
            else:  # only the parts the check looks at are read
                data = mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ)
    except OSError as exc:
        raise InputError("cannot read %s: %s" % (path, exc.strerror or exc)) from None
    try:
        return check(os.fspath(path), data)
    finally:
        if isinstance(data, mmap.mmap):
            data.close()


def fewer_faces(info):
    """The Qualification (core.validity) of the metrics of a BRep whose reader returned fewer
    faces (info['face_count']) than its file declares (info['declared']['declared_faces']):
    CAUTION from VALID or VALID*, with the counts; None when it returned them all."""
    from .validity import Qualification
    declared = (info.get("declared") or {}).get("declared_faces")
    read = info.get("face_count")
    if not declared or read is None or read >= declared:
        return None
    reason = ("the reader returned %d faces of the %d the file declares (%s): part of the file was not read"
              % (read, declared, info["declared"].get("declared_faces_rule", "surface entities")))
    return Qualification("fewer_faces_than_declared", reason, {"faces_declared": declared, "faces_read": read})
