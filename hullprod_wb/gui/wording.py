"""Validity labels in words a naval architect reads at a glance, with their colours."""
import re

#: A label of the paper's LaTeX source (eq:refs, tab:..., \\ref{...}) or its shorthand
#: ("c/a"): words for docstrings, never for what a person reads.
PAPER_LABEL = re.compile(r"\b(eq|tab|fig|sec):[A-Za-z]|\\[A-Za-z]{2,}\{|\bc/a\b")

#: status -> (one-line explanation, background colour '#rrggbb').
STATUS_TEXT = {
    "VALID": ("the value is established and can be used", "#2e8b57"),
    "VALID*": ("the integral converges although the surface has a singular point "
               "(e.g. a collapsed patch corner); the value can be used, see evidence", "#3c9d8f"),
    "CAUTION": ("a finite value that needs the qualification given in the reason", "#d4a017"),
    "MESH-SENSITIVE": ("this mesh value changes with mesh resolution, connectivity or quality: "
                       "compare a finer mesh or the native BRep before relying on it", "#e07b22"),
    "UNCONVERGED": ("refinement did not settle on a value, so none is reported", "#c0392b"),
    "SINGULAR": ("the curvature integral does not exist on this surface (non-integrable "
                 "singularity), so no value is reported", "#8e1b10"),
    "NOT EVALUATED": ("not computed in this run", "#7f8c8d"),
    "N/A": ("not applicable to this representation", "#95a5a6"),
}

METRIC_TEXT = {
    "I_D": "total developability (area-averaged |K| L_ref^2)",
    "I_D_plus": "elliptic (K > 0) part of I_D",
    "I_D_minus": "saddle (K < 0) part of I_D",
    "a_flat": "area fraction: flat",
    "a_single": "area fraction: singly curved (developable)",
    "a_elliptic": "area fraction: elliptic double curvature",
    "a_saddle": "area fraction: saddle / reverse double curvature",
}


def status_sentence(status):
    """'VALID*: the integral converges although ...' for a status label."""
    text, _ = STATUS_TEXT.get(status, ("unknown status", "#7f8c8d"))
    return "%s: %s" % (status, text)


def status_color(status):
    return STATUS_TEXT.get(status, ("", "#7f8c8d"))[1]


def format_value(value, digits=6):
    """A signature value for display; None (not established) shows as an em dash."""
    if value is None:
        return "\u2014"
    return "%.*g" % (digits, value)


#: Below this many mm² (0.01 m², a 100 mm square) an area of a millimetre model reads in mm².
MM2_PER_M2_THRESHOLD = 1e4


def area_text(value, unit, reference=None):
    """An area in words a naval architect reads: m² for a millimetre model whose area (or
    the reference area, e.g. the whole shape's, so that one table keeps one unit) is at least
    0.01 m², else the model's unit squared; unit is a length_unit_label (analysis.py)."""
    if value is None or value != value:
        return "n/a"
    u = str(unit or "model units")
    scale = abs(reference if reference is not None and reference == reference else value)
    if u == "mm" and scale >= MM2_PER_M2_THRESHOLD:
        return "%.6g m\u00b2" % (value / 1e6)
    if " " in u:
        return "%.6g (%s)\u00b2" % (value, u)
    return "%.6g %s\u00b2" % (value, u)


#: Face statuses under which a face's own I_D, I_D+, I_D- and a_C are not established.
UNESTABLISHED_FACE_STATUSES = ("UNCONVERGED", "SINGULAR", "NOT EVALUATED")


def face_value(rec, key):
    """A face record's own value of key ('I_D', 'I_D_plus', 'I_D_minus', 'a_C'), or None when the
    face's status leaves it not established (the number it holds is then no value)."""
    if str(rec.get("status", "VALID")) in UNESTABLISHED_FACE_STATUSES:
        return None
    return rec.get(key)


def unestablished_faces_note(faces, validity):
    """The sentence explaining plates that are not established under established totals
    (e.g. UNCONVERGED plates under a VALID* I_D), or '' when there are none."""
    bad = [f for f in faces if str(f.get("status")) in UNESTABLISHED_FACE_STATUSES]
    if not bad:
        return ""
    by = {}
    for f in bad:
        by.setdefault(str(f["status"]), []).append("Face%d" % f["face"])
    named = "; ".join("%s: %s" % (s, ", ".join(n[:12]) + (" and %d more" % (len(n) - 12) if len(n) > 12 else ""))
                      for s, n in sorted(by.items()))
    total = validity.get("I_D", {}).get("status")
    text = ("%d plate(s) not established (%s): their own values are not shown, and the plate view "
            "draws them in the not-established colour." % (len(bad), named))
    if total in ("VALID", "VALID*") and "UNCONVERGED" in by:
        text += (" The totals are %s all the same: a face's own integrals must meet its own "
                 "tolerance, while the totals need the summed error estimates of all faces to "
                 "meet the tolerance of the totals (one error budget for the shape), and they do."
                 % total)
    return text


#: Evidence entries that are areas (the denominator of I_D, I_D+, I_D-: A_K, eq:dev).
AREA_EVIDENCE = ("denominator",)


def evidence_text(evidence, unit, reference=None, limit=6):
    """'key = value; ...' of the first `limit` plain entries of a metric's evidence, the
    areas (AREA_EVIDENCE) in the unit area_text gives the reference area (so that they read
    as the represented area beside them does)."""
    parts = []
    for k, v in list(evidence.items())[:limit]:
        if isinstance(v, (dict, list)):
            continue
        if k in AREA_EVIDENCE and isinstance(v, (int, float)) and not isinstance(v, bool):
            text = area_text(v, unit, reference)
        else:
            text = format_value(v) if isinstance(v, float) else v
        parts.append("%s = %s" % (k, text))
    return "; ".join(parts)
