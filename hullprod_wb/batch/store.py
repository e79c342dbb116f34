"""The batch output folder: signatures.csv, cases/<case_id>.json, batch.json; resume.

A case counts as done when a previous run left a successful record for the same case id,
the same input content hash, the same variant parameters and the same settings hash.
Records are read from cases/*.json; a case with a table row but no JSON record (e.g. the
JSON files were removed) is recognised from signatures.csv. Failed cases are always rerun.
"""
import glob
import json
import os

from ..core import writers
from .table import PARAM_PREFIX, format_value, parse_row, read_table

TABLE_NAME = "signatures.csv"
CASES_DIR = "cases"
MANIFEST_NAME = "batch.json"


class BatchStore:
    """Files of one --out folder."""

    def __init__(self, out):
        from ..core.errors import InputError
        if os.path.exists(out) and not os.path.isdir(out):
            raise InputError("output path %s exists and is not a folder" % out)
        self.out = os.path.abspath(out)
        self.table_path = os.path.join(self.out, TABLE_NAME)
        self.cases_dir = os.path.join(self.out, CASES_DIR)
        self.manifest_path = os.path.join(self.out, MANIFEST_NAME)

    def prepare(self):
        os.makedirs(self.cases_dir, exist_ok=True)

    def record_path(self, case_id):
        return os.path.join(self.cases_dir, case_id + ".json")

    def write_record(self, record):
        """Write cases/<case_id>.json atomically."""
        path = self.record_path(record["case"]["case_id"])
        tmp = path + ".tmp"
        writers.write_json(tmp, record)
        os.replace(tmp, path)

    def write_manifest(self, doc):
        writers.write_json(self.manifest_path, doc)

    def previous(self):
        """case_id -> previous successful outcome {'case', 'settings_hash', 'row'} (typed row)."""
        found = {}
        for row in read_table(self.table_path):
            if row.get("status") == "ok" and row.get("case_id"):
                found[row["case_id"]] = {"row": parse_row(row), "text": row, "settings_hash": row.get("settings_hash")}
        for path in sorted(glob.glob(os.path.join(self.cases_dir, "*.json"))):
            try:
                with open(path, encoding="utf-8") as fh:
                    rec = json.load(fh)
                cid = rec["case"]["case_id"]
            except (OSError, ValueError, KeyError, TypeError):
                continue  # an unreadable record means: not done
            if rec.get("status") == "ok":
                found[cid] = {"case": rec["case"], "row": rec["row"], "settings_hash": rec.get("settings_hash")}
            else:
                found.pop(cid, None)
        return found

    @staticmethod
    def is_done(case, settings_hash, prev):
        """True when prev (an entry of previous()) is this case computed with these settings."""
        if prev is None or prev.get("settings_hash") != settings_hash:
            return False
        if "case" in prev:
            c = prev["case"]
            return (c.get("kind") == case.kind and c.get("sha256") == case.sha256
                    and (c.get("params") or {}) == case.params)
        text = prev["text"]
        params = {k[len(PARAM_PREFIX):]: v for k, v in text.items() if k.startswith(PARAM_PREFIX) and v != ""}
        return (text.get("kind") == case.kind and text.get("input_sha256") == case.sha256
                and params == {k: format_value(v) for k, v in case.params.items()})
