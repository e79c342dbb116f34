"""Batch cases: expand INPUTS (files, folders, glob patterns, FreeCAD documents with a
variant table) into a list of cases with stable ids, and hash the settings they run with.

A case is what one worker assesses: a hull file, or one row of a variant table applied to
a FreeCAD document. Its id is stable across runs (derived from the file name and content
hash, or the document name and the variant), so a later run over the same --out folder can
recognise cases already done (resume).
"""
import csv
import glob
import hashlib
import json
import os
import re
from dataclasses import asdict, dataclass, field

from ..core.errors import InputError
from ..core.inputs import BREP_FORMATS, MESH_FORMATS, sha256_file
from ..core.version import __version__

#: Extension of FreeCAD documents (a parametric hull, optionally with a variant table).
DOCUMENT_FORMATS = {".fcstd": "fcstd"}

#: Names of the optional variant-table column that names each variant.
VARIANT_NAME_COLUMNS = ("case", "variant", "name")

#: Assessment settings that enter the settings hash (and the assess() call); 'extra' holds
#: further keyword options of the backends (e.g. the BRep backend's display_deflection).
SETTING_KEYS = ("lref", "h_f", "k_f", "backend", "faces", "order", "rtol", "max_depth", "object", "extra")


@dataclass
class Case:
    """One assessment of a batch.

    case_id: stable id, also the JSON record's file name; kind: 'file' | 'variant';
    path: absolute path of the hull file or FreeCAD document; sha256: its content hash;
    representation: 'mesh' | 'brep'; params: variant parameter name -> value (empty for
    files); variant: the variant's name in its table (None for files).
    """

    case_id: str
    kind: str
    path: str
    sha256: str
    representation: str
    params: dict = field(default_factory=dict)
    variant: str = None

    def to_dict(self):
        return asdict(self)

    @classmethod
    def from_dict(cls, d):
        return cls(**{k: d.get(k) for k in ("case_id", "kind", "path", "sha256", "representation",
                                            "params", "variant")})


def canonical_json(obj):
    """Deterministic JSON text (sorted keys, no spaces) used for hashing."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), default=str)


def make_settings(lref=None, h_f=None, k_f=None, backend=None, faces=None, order=None, rtol=None,
                  max_depth=None, object=None, extra=None):
    """The settings dict of a batch (None entries mean: the backend's default).

    extra: further keyword options passed to assess() (backend-specific), e.g.
    {'display_deflection': 0.02}.
    """
    from ..core.constants import DEFAULT_HF, DEFAULT_KF
    return {"lref": None if lref is None else float(lref),
            "h_f": float(DEFAULT_HF if h_f is None else h_f),
            "k_f": float(DEFAULT_KF if k_f is None else k_f),
            "backend": backend,
            "faces": None if not faces else sorted(int(f) for f in faces),
            "order": None if order is None else int(order),
            "rtol": None if rtol is None else float(rtol),
            "max_depth": None if max_depth is None else int(max_depth),
            "object": object,
            "extra": dict(sorted((extra or {}).items()))}


def settings_hash(settings):
    """sha256 (16 hex digits) of the settings and the package version.

    Two runs share a hash exactly when they would compute the same thing for the same input.
    """
    payload = {k: settings.get(k) for k in SETTING_KEYS}
    payload["hullprod_wb"] = __version__
    return hashlib.sha256(canonical_json(payload).encode()).hexdigest()[:16]


def _slug(text):
    """File-name-safe form of text: letters, digits, '.', '_' and '-'."""
    s = re.sub(r"[^A-Za-z0-9._-]+", "_", text).strip("._")
    return s or "case"


def _kind_of(path):
    ext = os.path.splitext(path)[1].lower()
    if ext in MESH_FORMATS:
        return "mesh"
    if ext in BREP_FORMATS:
        return "brep"
    if ext in DOCUMENT_FORMATS:
        return "document"
    return None


def _known_extensions():
    return ", ".join(sorted(set(MESH_FORMATS) | set(BREP_FORMATS) | {".FCStd"}))


def expand_paths(inputs):
    """Files named by INPUTS, in order, without duplicates.

    A file is taken as given (an unknown extension is an error); a folder contributes every
    file of a known format below it (recursively, sorted); anything else is a glob pattern
    (``**`` allowed) whose matches of a known format are taken. A pattern or folder that
    yields nothing is an error.
    """
    if isinstance(inputs, (str, os.PathLike)):
        inputs = [inputs]
    out, seen = [], set()

    def add(p):
        p = os.path.abspath(p)
        if p not in seen:
            seen.add(p)
            out.append(p)

    for item in inputs:
        item = os.fspath(item)
        if os.path.isfile(item):
            if _kind_of(item) is None:
                raise InputError("unknown input format for %s (known: %s)" % (item, _known_extensions()))
            add(item)
            continue
        if os.path.isdir(item):
            found = sorted(p for p in glob.glob(os.path.join(glob.escape(item), "**", "*"), recursive=True)
                           if os.path.isfile(p) and _kind_of(p) in ("mesh", "brep"))
            if not found:
                raise InputError("folder %s holds no hull file (%s)" % (item, _known_extensions()))
        else:
            found = sorted(p for p in glob.glob(item, recursive=True) if os.path.isfile(p) and _kind_of(p))
            if not found:
                if glob.has_magic(item):
                    raise InputError("pattern %s matches no hull file (%s)" % (item, _known_extensions()))
                raise InputError("input not found: %s" % item)
        for p in found:
            add(p)
    if not out:
        raise InputError("no input given: name hull files, folders or glob patterns")
    return out


def _parse_value(text):
    """A table cell: int or float when it reads as one, else the stripped text (e.g. '12 m')."""
    t = text.strip()
    try:
        return int(t)
    except ValueError:
        pass
    try:
        return float(t)
    except ValueError:
        return t


def read_variant_table(path):
    """Read a variant table (CSV with a header row).

    Each column other than an optional case/variant/name column names a parameter: a
    spreadsheet alias (``L``) or an object property (``Body.Length``, ``Label.Property``).
    Returns (names, variants): names, the parameter names in column order; variants, a list
    of (variant_name, {parameter: value}) with variant_name from the name column or
    ``r001``, ``r002``, ... by row.
    """
    if not os.path.isfile(path):
        raise InputError("variant table not found: %s" % path)
    with open(path, newline="", encoding="utf-8-sig") as fh:
        sample = fh.read(4096)
        fh.seek(0)
        try:
            dialect = csv.Sniffer().sniff(sample, delimiters=",;\t")
        except csv.Error:
            dialect = csv.excel
        rows = [r for r in csv.reader(fh, dialect) if any(c.strip() for c in r)]
    if len(rows) < 2:
        raise InputError("variant table %s needs a header row and at least one variant row" % path)
    header = [h.strip() for h in rows[0]]
    if any(not h for h in header) or len(set(header)) != len(header):
        raise InputError("variant table %s: column names must be present and distinct, got %s" % (path, header))
    name_col = next((i for i, h in enumerate(header) if h.lower() in VARIANT_NAME_COLUMNS), None)
    names = [h for i, h in enumerate(header) if i != name_col]
    if not names:
        raise InputError("variant table %s has no parameter column" % path)
    variants, used = [], set()
    for k, r in enumerate(rows[1:], start=1):
        if len(r) != len(header):
            raise InputError("variant table %s, row %d: %d cells for %d columns" % (path, k + 1, len(r), len(header)))
        vname = _slug(r[name_col]) if name_col is not None and r[name_col].strip() else "r%03d" % k
        if vname in used:
            raise InputError("variant table %s: variant name %s appears twice" % (path, vname))
        used.add(vname)
        params = {}
        for i, h in enumerate(header):
            if i == name_col:
                continue
            if not r[i].strip():
                raise InputError("variant table %s, row %d: no value for %s" % (path, k + 1, h))
            params[h] = _parse_value(r[i])
        variants.append((vname, params))
    return names, variants


def expand_cases(inputs, variants=None, object_name=None, check_documents=True):
    """Cases of a batch from INPUTS and an optional variant table.

    Hull files give one case each (id: file stem and the first 8 hex digits of the content
    hash). A FreeCAD document gives one case per variant-table row (id: document stem and
    variant name), or a single case for its saved state when no table is given. With
    check_documents, each document is opened once here so that a table column naming no
    alias or property, or a missing --object, is reported before any work starts.
    """
    paths = expand_paths(inputs)
    table = read_variant_table(variants) if variants else None
    docs = [p for p in paths if _kind_of(p) == "document"]
    if table is not None and not docs:
        raise InputError("--variants applies to a FreeCAD document (.FCStd) among the inputs; none was given")
    if object_name and not docs:
        raise InputError("--object selects an object of a FreeCAD document (.FCStd); none was given")
    cases, ids = [], set()
    for p in paths:
        sha = sha256_file(p)
        stem = _slug(os.path.splitext(os.path.basename(p))[0])
        if _kind_of(p) == "document":
            if check_documents:
                from .parametric import check_document
                check_document(p, table[0] if table else [], object_name)
            rows = table[1] if table else [("saved", {})]
            new = [Case("%s-%s" % (stem, vname), "variant", p, sha, "brep", dict(params), vname)
                   for vname, params in rows]
        else:
            new = [Case("%s-%s" % (stem, sha[:8]), "file", p, sha, _kind_of(p))]
        for c in new:
            base, n = c.case_id, 2
            while c.case_id in ids:
                c.case_id = "%s~%d" % (base, n)
                n += 1
            ids.add(c.case_id)
            cases.append(c)
    return cases
