"""Exact keys of plain data: an unambiguous byte encoding (canonical_bytes: doubles as their
IEEE bytes, never through text) and its SHA-256, so that equal keys mean equal data bit for
bit (the BRep faces' store: brep.face_keys, brep.reading.record_keys).

Plain Python: the reading process, which never loads numpy, makes keys too.
"""
import hashlib
import pickle
import struct
from array import array

#: Hexadecimal digits of each half of a key (what it is of, then how it was made).
HALF = 32


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


def record_bytes(value):
    """The bytes of a large record of plain data (lists, tuples, dicts, floats, ints, strings,
    arrays), fast: its pickle (floats as their IEEE bytes, protocol 4). Different values give
    different bytes (the pickle gives the value back); equal values built alike give equal
    bytes (a value built with other sharing of its parts may differ: a miss, never a false
    hit)."""
    return pickle.dumps(value, protocol=4)


def digest(value):
    return hashlib.sha256(canonical_bytes(value)).hexdigest()


def derived_key(prefix, *parts):
    """A store key: prefix's first HALF digits (a digest of what the entry is of), then
    HALF digits of the digest of parts (how it was made)."""
    return prefix[:HALF] + digest(list(parts))[:HALF]
