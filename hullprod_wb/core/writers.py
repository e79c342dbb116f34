"""Writers: JSON document, one-row signature CSV, VTP and CSV field files.

JSON never carries NaN or infinity: non-finite numbers become null.
"""
import base64
import csv
import json
import math
import os

import numpy as np

from .constants import METRICS


def json_safe(obj):
    """Recursively convert numpy types to Python and non-finite floats to None."""
    t = type(obj)
    if t is float:
        return obj if math.isfinite(obj) else None
    if t is str or t is int or t is bool or obj is None:
        return obj
    if isinstance(obj, dict):
        return {str(k): json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return json_safe(obj.tolist())
    if isinstance(obj, (np.bool_, bool)):
        return bool(obj)
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        x = float(obj)
        return x if math.isfinite(x) else None
    if hasattr(obj, "to_dict"):
        return json_safe(obj.to_dict())
    if hasattr(obj, "value") and isinstance(getattr(obj, "value"), str):  # enums
        return obj.value
    return obj


#: Levels of a document that dumps lays out one member a line; deeper values are written on
#: one line each (a face's record, a list of numbers).
LAID_OUT_LEVELS = 3
_ONE_LINE = json.JSONEncoder(allow_nan=False, separators=(", ", ": ")).encode


def dumps(doc, indent=2, checked=False):
    """Strict JSON text (no NaN: json_safe and allow_nan=False). indent None: one line; else
    the first LAID_OUT_LEVELS levels one member a line, indented, and each deeper value on
    its line (the encoder's fast path). checked: doc is json_safe's output already (a
    result's to_dict), not walked again."""
    safe = doc if checked else json_safe(doc)
    if indent is None:
        return _ONE_LINE(safe)
    return _laid_out(safe, " " * indent, 0)


def _laid_out(obj, step, level):
    if level >= LAID_OUT_LEVELS or not obj or not isinstance(obj, (dict, list)):
        return _ONE_LINE(obj)
    inner = "\n" + step * (level + 1)
    if isinstance(obj, dict):
        parts = [_ONE_LINE(k) + ": " + _laid_out(v, step, level + 1) for k, v in obj.items()]
        return "{" + inner + ("," + inner).join(parts) + "\n" + step * level + "}"
    parts = [_laid_out(v, step, level + 1) for v in obj]
    return "[" + inner + ("," + inner).join(parts) + "\n" + step * level + "]"


def write_json(path, doc, checked=False):
    """doc as dumps writes it (checked: as dumps's), and a newline, into path."""
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(dumps(doc, checked=checked))
        fh.write("\n")


def signature_row(doc):
    """Flat one-row mapping of a signature document (values and statuses)."""
    row = {"input": doc["input"].get("path"), "sha256": doc["input"].get("sha256"),
           "representation": doc["input"].get("representation"),
           "L_ref": doc["reference_length"]["value"]}
    for m in METRICS:
        rec = doc["validity"][m]
        row[m] = rec["value"]
        row[m + "_status"] = rec["status"]
    row["represented_area"] = doc["validity"]["I_D"]["represented_area"]
    row["valid_area"] = doc["validity"]["I_D"]["valid_area"]
    return row


def length_unit(doc):
    """The unit of the document's lengths: the working unit of a BRep (millimetres for IGES
    and STEP), else 'model units' (a mesh carries the numbers of its file)."""
    units = (doc.get("provenance") or {}).get("units") or {}
    return units.get("working_unit") or "model units"


def write_signature_csv(path, doc):
    """signature.csv: the one row of signature_row, its length and area columns headed with
    their unit (I_D, I_D+-, a_C are dimensionless)."""
    unit = length_unit(doc)
    named = {"L_ref": "L_ref [%s]" % unit, "represented_area": "represented_area [%s^2]" % unit,
             "valid_area": "valid_area [%s^2]" % unit}
    row = {named.get(k, k): v for k, v in signature_row(doc).items()}
    with open(path, "w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=list(row))
        w.writeheader()
        w.writerow({k: ("" if v is None else v) for k, v in row.items()})


def write_fields_csv(path, fields):
    """One row per sample: x, y, z and every point array of the fields."""
    arrays = fields.point_arrays()
    cols = [fields.points[:, 0], fields.points[:, 1], fields.points[:, 2]] + list(arrays.values())
    header = ["x", "y", "z"] + list(arrays)
    data = np.column_stack([np.asarray(c, dtype=float) for c in cols])
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(",".join(header) + "\n")
        np.savetxt(fh, data, delimiter=",", fmt="%.17g")
    # NaN is written as 'nan', which spreadsheet tools and numpy read back as missing.


_VTK_TYPES = {np.dtype(np.float64): "Float64", np.dtype(np.float32): "Float32",
              np.dtype(np.int32): "Int32", np.dtype(np.int64): "Int64",
              np.dtype(np.uint8): "UInt8", np.dtype(np.int8): "Int8"}


def _data_array(name, arr, ncomp=1):
    arr = np.ascontiguousarray(arr)
    if arr.dtype not in _VTK_TYPES:
        arr = arr.astype(np.float64)
    raw = arr.tobytes()
    payload = base64.b64encode(np.uint64(len(raw)).tobytes() + raw).decode("ascii")
    return ('<DataArray type="%s" Name="%s" NumberOfComponents="%d" format="binary">%s</DataArray>'
            % (_VTK_TYPES[arr.dtype], name, ncomp, payload))


def write_vtp(path, fields):
    """VTK XML PolyData (base64 binary, UInt64 headers) that ParaView opens."""
    pts = np.asarray(fields.points, dtype=np.float64)
    tri = np.asarray(fields.triangles, dtype=np.int64)
    n, m = len(pts), len(tri)
    parts = ['<?xml version="1.0"?>',
             '<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian" header_type="UInt64">',
             '<PolyData>',
             '<Piece NumberOfPoints="%d" NumberOfVerts="0" NumberOfLines="0" NumberOfStrips="0" '
             'NumberOfPolys="%d">' % (n, m),
             '<PointData Scalars="q_D">']
    for name, arr in fields.point_arrays().items():
        parts.append(_data_array(name, arr))
    parts += ['</PointData>', '<Points>', _data_array("Points", pts, 3), '</Points>', '<Polys>',
              _data_array("connectivity", tri.reshape(-1)),
              _data_array("offsets", np.arange(3, 3 * m + 1, 3, dtype=np.int64)),
              '</Polys>', '</Piece>', '</PolyData>', '</VTKFile>']
    with open(path, "w", encoding="ascii") as fh:
        fh.write("\n".join(parts))
        fh.write("\n")


def prepare_output_dir(path, overwrite=False):
    """Create path; refuse a non-empty existing folder unless overwrite is set."""
    from .errors import InputError
    if os.path.exists(path) and not os.path.isdir(path):
        raise InputError("output path %s exists and is not a folder" % path)
    if os.path.isdir(path) and os.listdir(path) and not overwrite:
        raise InputError("output folder %s is not empty; choose another or pass --overwrite" % path)
    os.makedirs(path, exist_ok=True)
    return path
