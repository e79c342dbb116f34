"""The batch table signatures.csv: one row per case, written as cases finish.

Columns: case identity (id, kind, input path, content hash, variant name and one
``param.<name>`` column per variant parameter), the assessed object and representation,
L_ref, the seven signature entries (paper eq:vector) and their validity statuses, the
represented and valid areas, the valid area fraction A_K / A, warnings, the case status
('ok' | 'error') with the error message, the settings hash, the case time limit
(case_timeout_s, empty: none) and the case runtime.
A value that is not established is an empty cell, never a number.
"""
import csv
import math
import os

from ..core.constants import METRICS
from ..core.writers import signature_row

PARAM_PREFIX = "param."

#: Columns that differ between two runs of the same cases (wall-clock measurements).
TIMING_COLUMNS = ("runtime_s",)

#: Numeric columns (parsed back to float, empty -> None).
NUMERIC_COLUMNS = ("L_ref",) + METRICS + ("represented_area", "valid_area", "valid_area_fraction", "runtime_s",
                                          "case_timeout_s")

_HEAD = ("case_id", "kind", "input", "input_sha256", "variant")
_TAIL = (("object", "representation", "L_ref", "L_ref_mode") + METRICS + tuple(m + "_status" for m in METRICS)
         + ("represented_area", "valid_area", "valid_area_fraction", "warnings", "status", "error",
            "settings_hash", "case_timeout_s") + TIMING_COLUMNS)


def columns(param_names=()):
    """Column names of a table whose variants set param_names (in that order)."""
    return list(_HEAD) + [PARAM_PREFIX + n for n in param_names] + list(_TAIL)


def make_row(case, settings_hash, doc=None, error=None, runtime=None, object_name=None, case_timeout=None):
    """Table row (typed values) of a finished case (case_timeout: its time limit in
    seconds, None: none).

    doc: the assessment's JSON document (Assessment.to_dict()) or None when the case
    failed; error: one-line error message or None.
    """
    row = {"case_id": case.case_id, "kind": case.kind, "input": case.path, "input_sha256": case.sha256,
           "variant": case.variant}
    for name, value in case.params.items():
        row[PARAM_PREFIX + name] = value
    row.update({"object": object_name, "representation": case.representation, "L_ref": None,
                "L_ref_mode": None})
    row.update({m: None for m in METRICS})
    row.update({m + "_status": None for m in METRICS})
    row.update({"represented_area": None, "valid_area": None, "valid_area_fraction": None, "warnings": None})
    if doc is not None:
        sig = signature_row(doc)
        row["representation"] = sig["representation"] or case.representation
        row["L_ref"] = sig["L_ref"]
        row["L_ref_mode"] = doc["reference_length"].get("mode")
        for m in METRICS:
            row[m] = sig[m]
            row[m + "_status"] = sig[m + "_status"]
        A, A_K = sig["represented_area"], sig["valid_area"]
        row["represented_area"], row["valid_area"] = A, A_K
        row["valid_area_fraction"] = A_K / A if A and A_K is not None else None
        row["warnings"] = " | ".join(" ".join(str(w).split()) for w in doc.get("warnings") or []) or None
    row["status"] = "error" if error else "ok"
    row["error"] = " ".join(str(error).split()) if error else None
    row["settings_hash"] = settings_hash
    row["case_timeout_s"] = None if case_timeout is None else float(case_timeout)
    row["runtime_s"] = None if runtime is None else round(float(runtime), 4)
    return row


def format_value(v):
    """CSV text of a value: '' for None or non-finite, repr for floats (round-trips exactly)."""
    if v is None:
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else ""
    return str(v)


def format_row(row, cols):
    return {c: format_value(row.get(c)) for c in cols}


def parse_row(text_row):
    """Typed row from CSV text (numbers in NUMERIC_COLUMNS and param columns, '' -> None)."""
    from .cases import _parse_value
    out = {}
    for k, v in text_row.items():
        if v == "" or v is None:
            out[k] = None
        elif k in NUMERIC_COLUMNS:
            out[k] = float(v)
        elif k.startswith(PARAM_PREFIX):
            out[k] = _parse_value(v)
        else:
            out[k] = v
    return out


def read_table(path):
    """Rows of an existing signatures.csv as dicts of text ([] when absent or unreadable)."""
    if not os.path.isfile(path):
        return []
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            return list(csv.DictReader(fh))
    except (OSError, csv.Error, UnicodeDecodeError):
        return []


class TableWriter:
    """Streams rows to path: header first, each row flushed to disk as it is written."""

    def __init__(self, path, cols):
        self.path = path
        self.cols = list(cols)
        self._fh = open(path, "w", newline="", encoding="utf-8")
        self._w = csv.DictWriter(self._fh, fieldnames=self.cols, extrasaction="ignore")
        self._w.writeheader()
        self._fh.flush()

    def write(self, row):
        """Append one typed row and flush it."""
        self._w.writerow(format_row(row, self.cols))
        self._fh.flush()

    def close(self):
        if not self._fh.closed:
            self._fh.close()


def write_table(path, rows, cols):
    """Write the whole table at once (atomically: temporary file, then rename)."""
    tmp = path + ".tmp"
    with open(tmp, "w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=list(cols), extrasaction="ignore")
        w.writeheader()
        for row in rows:
            w.writerow(format_row(row, cols))
    os.replace(tmp, path)
