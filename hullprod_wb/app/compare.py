"""Side-by-side comparison of analyses, with the reasons two signatures are not like for like.

The signature is dimensionless only under a stated L_ref convention and thresholds, and
the two realizations (BRep, mesh) are different estimators (paper section 4): comparisons
across either are flagged, not forbidden.
"""
import math

from ..core.constants import METRICS
from ..core.errors import InputError
from .analysis import is_analysis, length_unit_label, result_document, signature_of

#: L_ref / automatic-span ratios differing by more than this fraction mean different
#: length conventions (e.g. L_pp against overall length: typically 3 % or more).
LREF_CONVENTION_TOL = 0.02


def _ratio(obj):
    if obj.LrefAutomatic > 0 and not math.isnan(obj.LrefAutomatic):
        return obj.LrefUsed / obj.LrefAutomatic
    return float("nan")


def comparison_flags(objs):
    """Plain-language reasons the analyses are not like for like ([] when they are)."""
    flags = []

    def differs(getter, text):
        vals = {o.Label: getter(o) for o in objs}
        if len(set(vals.values())) > 1:
            flags.append(text + ": " + ", ".join("%s %s" % (k, v) for k, v in vals.items()))

    differs(lambda o: o.Representation, "different representations (BRep and mesh are different estimators)")
    differs(lambda o: o.LrefUsedMode, "different L_ref modes")
    differs(lambda o: "h_f=%g k_f=%g" % (o.Hf, o.Kf), "different class thresholds")
    differs(length_unit_label, "different length units")
    lrefs = {o.Label: o.LrefUsed for o in objs}
    if min(lrefs.values()) > 0 and max(lrefs.values()) > (1 + LREF_CONVENTION_TOL) * min(lrefs.values()):
        flags.append("L_ref differs by a factor %.3g (%s): I_D scales with L_ref^2, so the values are not "
                     "comparable; give both the same explicit L_ref"
                     % (max(lrefs.values()) / min(lrefs.values()),
                        ", ".join("%s %.6g %s" % (k, v, length_unit_label(o)) for (k, v), o in zip(lrefs.items(), objs))))
    ratios = {o.Label: _ratio(o) for o in objs}
    finite = [r for r in ratios.values() if not math.isnan(r)]
    if finite and (max(finite) - min(finite)) > LREF_CONVENTION_TOL * max(finite):
        flags.append("different L_ref conventions (L_ref / principal-axis span: %s)"
                     % ", ".join("%s %.3f" % (k, v) for k, v in ratios.items()))
    brep = [o for o in objs if o.Representation == "brep"]
    if len(brep) > 1:
        differs_q = {(o.QuadratureOrder, o.QuadratureRtol, o.QuadratureMaxDepth) for o in brep}
        if len(differs_q) > 1:
            flags.append("different BRep quadrature settings (order, rtol, max depth)")
    for o in objs:
        try:
            count = result_document(o).get("input", {}).get("face_count")
        except InputError:
            count = None
        if count and o.FacesUsed and len(o.FacesUsed) < count:
            flags.append("%s assesses only faces %s of %d" % (o.Label, ",".join(map(str, o.FacesUsed)), count))
        if o.Status != "ok":
            flags.append("%s is not up to date (%s)" % (o.Label, o.Status))
    return flags


def open_analyses():
    """Every HullProd analysis of every open document, document by document."""
    import FreeCAD
    from .analysis import analyses_in
    return [a for doc in FreeCAD.listDocuments().values() for a in analyses_in(doc)]


def display_labels(objs):
    """A name per analysis a person can tell apart: its label, with its document's label in
    front when the analyses come from more than one document."""
    docs = {o.Document.Name for o in objs}
    if len(docs) < 2:
        return [o.Label for o in objs]
    return ["%s: %s" % (o.Document.Label, o.Label) for o in objs]


def compare_analyses(objs):
    """dict(labels, metrics, values {metric: [value or None]}, statuses, context, flags)."""
    objs = list(objs)
    if len(objs) < 2 or not all(is_analysis(o) for o in objs):
        raise InputError("select two or more HullProd analyses to compare")
    sigs = [signature_of(o) for o in objs]
    return {
        "labels": display_labels(objs),
        "metrics": list(METRICS),
        "values": {m: [s[m]["value"] for s in sigs] for m in METRICS},
        "statuses": {m: [s[m]["status"] for s in sigs] for m in METRICS},
        "context": [{"representation": o.Representation, "L_ref": o.LrefUsed, "L_ref mode": o.LrefUsedMode,
                     "h_f": o.Hf, "k_f": o.Kf, "units": length_unit_label(o),
                     "faces": ",".join(map(str, o.FacesUsed)) or "all"} for o in objs],
        "flags": comparison_flags(objs),
    }
