"""The keys of the BRep faces' results in the store (core.result_store).

A face's result depends on its exact geometry and on everything its integration is given:
the reference length and thresholds, the quadrature settings, the face's point budget (its
share of the shape's budget), whether it is integrated alone (in patch groups), the
cross-checks, and the software (this package's source, numpy, OpenCascade). The key is
two digests: of the geometry (geometry_digest: the face's record, occ_records.FaceData,
without its number, so a face keeps its key when others are added before it) and of the rest
(settings_digest, then face_key with the budget). Both are SHA-256 over an exact encoding
(canonical_bytes: doubles as their 8 bytes, never through text), so equal keys mean equal
inputs bit for bit, and the stored result is the one a fresh integration would give.
"""
import hashlib
import os
import platform
import struct
import sys
from array import array
from dataclasses import fields

from ..core import version

PACKAGE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
#: Hexadecimal digits of each half of a key (the geometry's, then the settings').
HALF = 32
_FINGERPRINT = None


def canonical_bytes(value, out=None):
    """An exact, unambiguous byte encoding of plain data: None, bool, int, float (its IEEE
    bytes), str, bytes, array, numpy arrays, and lists, tuples and dicts of them (dicts in
    their order)."""
    out = bytearray() if out is None else out
    if value is None:
        out += b"N"
    elif isinstance(value, bool):
        out += b"T" if value else b"F"
    elif isinstance(value, int):
        s = str(value).encode()
        out += b"i%d:" % len(s) + s
    elif isinstance(value, float):
        out += b"d" + struct.pack("<d", value)
    elif isinstance(value, str):
        s = value.encode("utf-8")
        out += b"s%d:" % len(s) + s
    elif isinstance(value, (bytes, bytearray)):
        out += b"b%d:" % len(value) + bytes(value)
    elif isinstance(value, array):
        out += b"a%s%d:" % (value.typecode.encode(), len(value)) + value.tobytes()
    elif isinstance(value, (list, tuple)):
        out += b"l%d:" % len(value)
        for v in value:
            canonical_bytes(v, out)
    elif isinstance(value, dict):
        out += b"m%d:" % len(value)
        for k, v in value.items():
            canonical_bytes(k, out)
            canonical_bytes(v, out)
    elif hasattr(value, "dtype") and hasattr(value, "tobytes"):  # a numpy array or scalar
        out += b"n%s%s:" % (str(value.dtype).encode(), str(getattr(value, "shape", ())).encode())
        out += value.tobytes()
    else:
        raise TypeError("no exact encoding of %s" % type(value).__name__)
    return out


def digest(value):
    return hashlib.sha256(canonical_bytes(value)).hexdigest()


def software_fingerprint():
    """Digest of what computes a face: this package's version and Python sources, numpy's
    version, the Python version and the machine (made once a process)."""
    global _FINGERPRINT
    if _FINGERPRINT is None:
        import numpy
        h = hashlib.sha256()
        h.update(canonical_bytes([version.__version__, numpy.__version__, list(sys.version_info[:2]), platform.machine()]))
        for root, dirs, files in os.walk(PACKAGE):
            dirs[:] = sorted(d for d in dirs if d != "__pycache__")
            for name in sorted(files):
                if name.endswith(".py"):
                    path = os.path.join(root, name)
                    h.update(os.path.relpath(path, PACKAGE).encode())
                    with open(path, "rb") as fh:
                        h.update(fh.read())
        _FINGERPRINT = h.hexdigest()
    return _FINGERPRINT


def record_digest(rec):
    """Digest of a face's record (occ_records.FaceData) without its number and its index
    among the faces sent (part); None for a face sent as OpenCascade's data whose data has
    no digest."""
    if rec.as_data and rec.data_digest is None:
        return None
    return digest([getattr(rec, f.name) for f in fields(rec) if f.name not in ("number", "part")])


def geometry_digest(face):
    """record_digest of a face: a recorded_shape.FaceRecord's record, or a Part.Face's made
    here (occ_records.face_record, else the record of its data); None when it has none."""
    rec = getattr(face, "rec", None)
    if rec is None:
        from .reading.occ_records import face_record
        from .reading.record_reader import part_record
        try:
            rec, why = face_record(face, 0, 0)
            if rec is None:
                rec = part_record(face, why, 0, 0)
        except Exception:  # OpenCascade cannot describe the face: it is integrated, never stored
            return None
    return record_digest(rec)


def settings_digest(lref, thresholds, opts, alone, cross_checks, occ_version, reading):
    """Digest of what every face of a run is integrated with: L_ref, the thresholds (tau_H,
    tau_K), the quadrature options (budget.QuadratureOptions), whether a face is integrated
    alone (in patch groups), the cross-checks, OpenCascade's version, how the faces were
    read (the run's kind) and the software_fingerprint."""
    return digest([software_fingerprint(), float(lref), float(thresholds.tau_H), float(thresholds.tau_K),
                   sorted(opts.record().items()), bool(alone), bool(cross_checks), occ_version, reading])


def face_key(geometry, settings, budget):
    """The store key of a face of geometry digest geometry, integrated with settings
    (settings_digest) within budget points (None: no limit): the geometry's first HALF
    digits, then HALF of the rest's."""
    return geometry[:HALF] + digest([settings, budget])[:HALF]
