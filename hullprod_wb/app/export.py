"""Export of an analysis: signature JSON and CSV, VTP and CSV fields (the files of
Assessment.save), written from what the analysis object stores, so it works after the
document was reopened. Report writers (e.g. an HTML report) register through a hook.
"""
import os

from ..core import writers
from ..core.errors import InputError
from .analysis import analysis_fields, is_analysis, result_document

#: name -> callable(obj, doc, fields, folder) returning a path; see register_report_writer.
REPORT_WRITERS = {}


def register_report_writer(name, func):
    """Add a further export format (e.g. 'html'): func(obj, doc, fields, folder) -> path."""
    REPORT_WRITERS[name] = func


def csv_document(doc):
    """doc with the input named for the one-row CSV: a FreeCAD object, which has no file
    path, as 'FreeCAD object NAME (LABEL) in DOCUMENT'."""
    inp = doc.get("input", {})
    if inp.get("path") or not inp.get("name"):
        return doc
    where = " in %s" % inp["document"] if inp.get("document") else ""
    named = dict(inp, path="FreeCAD object %s (%s)%s" % (inp.get("object", inp["name"]), inp["name"], where))
    return dict(doc, input=named)


def export_analysis(obj, folder, overwrite=False, formats=None):
    """Write obj's results into folder; returns name -> path.

    Files: signature.json (the full JSON document), signature.csv (one row), and with
    fields fields.vtp (ParaView) and fields.csv; plus any registered report writer named
    in formats (default: the four files above, and every registered writer).
    """
    if not is_analysis(obj):
        raise InputError("%s is not a HullProd analysis" % getattr(obj, "Label", obj))
    doc = result_document(obj)
    fields = analysis_fields(obj)
    wanted = set(formats) if formats else {"json", "csv", "vtp", "fields_csv"} | set(REPORT_WRITERS)
    unknown = wanted - {"json", "csv", "vtp", "fields_csv"} - set(REPORT_WRITERS)
    if unknown:
        raise InputError("unknown export format(s) %s (known: json, csv, vtp, fields_csv%s)"
                         % (", ".join(sorted(unknown)), "".join(", " + k for k in sorted(REPORT_WRITERS))))
    writers.prepare_output_dir(folder, overwrite)
    paths = {}
    if "json" in wanted:
        paths["json"] = os.path.join(folder, "signature.json")
        writers.write_json(paths["json"], doc)
    if "csv" in wanted:
        paths["csv"] = os.path.join(folder, "signature.csv")
        writers.write_signature_csv(paths["csv"], csv_document(doc))
    if fields is not None and "vtp" in wanted:
        paths["vtp"] = os.path.join(folder, "fields.vtp")
        writers.write_vtp(paths["vtp"], fields)
    if fields is not None and "fields_csv" in wanted:
        paths["fields_csv"] = os.path.join(folder, "fields.csv")
        writers.write_fields_csv(paths["fields_csv"], fields)
    for name, func in REPORT_WRITERS.items():
        if name in wanted:
            paths[name] = func(obj, doc, fields, folder)
    return paths
