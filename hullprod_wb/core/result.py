"""The assessment record: signature, per-metric validity, fields, provenance (paper
eq:signature), with its JSON document and file outputs."""
import os
import platform
from dataclasses import dataclass, field

from . import writers
from .constants import CLASS_METRICS, CLASS_NAMES, METRIC_LABELS, METRICS, SCHEMA_VERSION
from .validity import STATUS_MEANING
from .version import __version__


def dist_version(name):
    """Version of an installed distribution from its metadata folder's name
    (name-VERSION.dist-info or .egg-info on sys.path), without importing it or importlib.metadata
    (both cost start-up time); importlib.metadata where the name does not tell.
    None when not installed."""
    import glob
    import sys
    for folder in sys.path:
        for meta in sorted(glob.glob(os.path.join(folder or ".", name + "-*.*-info"))):
            stem = os.path.basename(meta).rsplit(".", 1)[0][len(name) + 1:]
            found = stem.split("-py")[0]
            if found and found[0].isdigit():
                return found
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version(name)
    except PackageNotFoundError:
        return None


def software_versions(with_freecad=True):
    """Versions of this package and of what it computes with (None where absent; FreeCAD
    and OCC None without with_freecad unless FreeCAD is loaded: a mesh does not use it)."""
    import numpy
    from ..freecad_env import versions
    out = {"package": "hullprod_wb", "version": __version__, "python": platform.python_version(),
           "numpy": numpy.__version__, "scipy": dist_version("scipy"), "trimesh": dist_version("trimesh")}
    out.update(versions(load=with_freecad))
    return out


@dataclass
class Assessment:
    """Outcome of one assessment.

    input: path, sha256, format, representation ('brep' | 'mesh'), and for BRep the faces
    used; reference_length: a ReferenceLength; thresholds: a Thresholds; integrals: the
    SurfaceIntegrals; validity: metric name -> MetricValidity; fields: DistributedFields
    or None; provenance, options, timings: plain dicts.
    """

    input: dict
    reference_length: object
    thresholds: object
    integrals: object
    validity: dict
    fields: object = None
    provenance: dict = field(default_factory=dict)
    options: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)

    @property
    def signature(self):
        """Established values only: a metric not established is None (never a candidate)."""
        v = {m: self.validity[m].value for m in METRICS}
        return {"I_D": v["I_D"], "I_D_plus": v["I_D_plus"], "I_D_minus": v["I_D_minus"],
                "a_C": {n: v[m] for n, m in zip(CLASS_NAMES, CLASS_METRICS)}}

    @property
    def vector(self):
        """The seven entries of I_sig in paper order (eq:vector), None where not established."""
        return [self.validity[m].value for m in METRICS]

    def to_dict(self):
        doc = {
            "schema_version": SCHEMA_VERSION,
            "software": software_versions(self.input.get("representation") != "mesh"),
            "input": self.input,
            "reference_length": self.reference_length.to_dict(),
            "thresholds": self.thresholds.to_dict(),
            "signature": self.signature,
            "validity": {m: self.validity[m].to_dict() for m in METRICS},
            "integrals": self.integrals.to_dict(),
            "provenance": self.provenance,
            "options": self.options,
            "timings": self.timings,
            "warnings": list(self.warnings),
        }
        return writers.json_safe(doc)

    def to_json(self, indent=2):
        return writers.dumps(self.to_dict(), indent=indent, checked=True)

    def save(self, directory, overwrite=False):
        """Write signature.json, signature.csv and, with fields, fields.vtp and fields.csv.

        Refuses a non-empty existing folder unless overwrite. Returns name -> path.
        """
        writers.prepare_output_dir(directory, overwrite)
        doc = self.to_dict()
        paths = {"json": os.path.join(directory, "signature.json"),
                 "csv": os.path.join(directory, "signature.csv")}
        writers.write_json(paths["json"], doc, checked=True)
        writers.write_signature_csv(paths["csv"], doc)
        if self.fields is not None:
            paths["vtp"] = os.path.join(directory, "fields.vtp")
            paths["fields_csv"] = os.path.join(directory, "fields.csv")
            writers.write_vtp(paths["vtp"], self.fields)
            writers.write_fields_csv(paths["fields_csv"], self.fields)
        return paths

    def summary_table(self):
        """Plain-text signature table with validity labels and reasons."""
        rl = self.reference_length
        lines = ["HullProd signature of %s (%s)" % (self.input.get("path") or self.input.get("name", "?"),
                                                  self.input.get("representation")),
                 "L_ref = %.6g (%s)  h_f = %g  k_f = %g" % (rl.value, rl.mode, self.thresholds.h_f,
                                                           self.thresholds.k_f),
                 "%-11s %16s  %-14s %s" % ("metric", "value", "status", "reason")]
        for m in METRICS:
            rec = self.validity[m]
            val = "null" if rec.value is None else "%.8g" % rec.value
            lines.append("%-11s %16s  %-14s %s" % (METRIC_LABELS[m], val, rec.status.value,
                                                   rec.reason or STATUS_MEANING[rec.status]))
        ig = self.integrals
        lines.append("represented area %.10g, valid area %.10g" % (ig.represented_area, ig.valid_area))
        for w in self.warnings:
            lines.append("warning: " + w)
        return "\n".join(lines)
