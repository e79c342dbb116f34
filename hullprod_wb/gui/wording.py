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
