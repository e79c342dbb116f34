"""Self-contained HTML report of an assessment and/or verification studies.

One HTML file, no external resources: images are embedded as base64 PNG data URIs.
Sections: input and settings; the signature table with validity labels and reasons;
represented and valid areas; the developability-density and curvature-class maps
(:mod:`.render`) of the distributed fields; the per-face table (BRep); mesh quality
(mesh); the remaining provenance; warnings; and one section per study (same-face,
refinement, representation, thresholds).
"""
import base64
import datetime
import html
import json
import os

from ..core.constants import CLASS_NAMES, METRIC_LABELS, METRICS
from ..core.errors import InputError
from ..core.validity import STATUS_MEANING, Status

STATUS_COLOURS = {"VALID": "#1b7837", "VALID*": "#5aae61", "CAUTION": "#d9a400", "UNCONVERGED": "#c51b7d",
                  "SINGULAR": "#8e0152", "MESH-SENSITIVE": "#e08214", "NOT EVALUATED": "#777777",
                  "N/A": "#999999"}

CSS = """
body{font-family:sans-serif;max-width:1100px;margin:1.5em auto;color:#222;font-size:14px}
h1{font-size:1.5em}h2{font-size:1.2em;border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:1.6em}
h3{font-size:1.05em}
table{border-collapse:collapse;margin:.5em 0 1em 0;font-size:13px}
th,td{border:1px solid #ccc;padding:3px 7px;text-align:right;vertical-align:top}
th{background:#f0f0f0}td.l,th.l{text-align:left}
.badge{display:inline-block;padding:1px 6px;border-radius:3px;color:#fff;font-size:12px;font-weight:bold}
.note{color:#555;font-size:12px}img{max-width:100%;border:1px solid #ddd}
details{margin:.5em 0}pre{background:#f7f7f7;padding:.5em;overflow-x:auto;font-size:12px}
"""


# ---------------------------------------------------------------------------------------------
# small HTML helpers


def esc(x):
    return html.escape("" if x is None else str(x))


def fmt(x, digits=6):
    """Number formatting for tables: None -> '-', floats with `digits` significant digits."""
    if x is None:
        return "-"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, int):
        return str(x)
    if isinstance(x, float):
        return "%.*g" % (digits, x)
    return str(x)


def pct(x, digits=3):
    return "-" if x is None else "%.*f" % (digits, 100.0 * x)


def table(headers, rows, left=()):
    """HTML table; cells are escaped text (strings) unless wrapped by :class:`Raw`."""
    out = ["<table><tr>"]
    out += ['<th class="l">%s</th>' % esc(h) if i in left else "<th>%s</th>" % esc(h)
            for i, h in enumerate(headers)]
    out.append("</tr>")
    for r in rows:
        out.append("<tr>")
        for i, c in enumerate(r):
            cls = ' class="l"' if i in left else ""
            out.append("<td%s>%s</td>" % (cls, c.html if isinstance(c, Raw) else esc(c)))
        out.append("</tr>")
    out.append("</table>")
    return "".join(out)


class Raw:
    """Pre-formatted HTML for a table cell."""

    def __init__(self, html_text):
        self.html = html_text


def badge(status):
    s = str(status)
    return Raw('<span class="badge" style="background:%s">%s</span>' % (STATUS_COLOURS.get(s, "#777"), esc(s)))


def png_img(png, alt):
    return '<img alt="%s" src="data:image/png;base64,%s">' % (esc(alt), base64.b64encode(png).decode("ascii"))


def flatten(d, prefix=""):
    """[(dotted key, value)] of nested dicts; lists of scalars joined, lists of dicts as JSON."""
    out = []
    for k, v in (d or {}).items():
        key = "%s%s" % (prefix, k)
        if isinstance(v, dict):
            out += flatten(v, key + ".")
        elif isinstance(v, (list, tuple)) and all(not isinstance(x, (dict, list, tuple)) for x in v):
            out.append((key, ", ".join(fmt(x) for x in v)))
        elif isinstance(v, (list, tuple)):
            out.append((key, json.dumps(v, default=str)[:2000]))
        else:
            out.append((key, fmt(v)))
    return out


def kv_table(d):
    return table(["item", "value"], flatten(d), left=(0, 1))


# ---------------------------------------------------------------------------------------------
# assessment sections


def signature_section(a):
    rl, th = a.reference_length, a.thresholds
    parts = ["<h2>Signature</h2>",
             '<p>L<sub>ref</sub> = %s (%s), h<sub>f</sub> = %s, k<sub>f</sub> = %s '
             '(&tau;<sub>H</sub> = %s, &tau;<sub>K</sub> = %s)</p>'
             % (esc(fmt(rl.value, 8)), esc(rl.mode), esc(fmt(th.h_f)), esc(fmt(th.k_f)),
                esc(fmt(th.tau_H)), esc(fmt(th.tau_K)))]
    rows = []
    for m in METRICS:
        rec = a.validity[m]
        rows.append([METRIC_LABELS[m], fmt(rec.value, 8), badge(rec.status),
                     rec.reason or STATUS_MEANING[rec.status], rec.code])
    parts.append(table(["metric", "value", "status", "reason", "code"], rows, left=(0, 3, 4)))
    ig = a.integrals
    frac = ig.valid_area / ig.represented_area if ig.represented_area > 0 else None
    parts.append("<p>Represented area %s, valid area %s (%s %% of the represented area).</p>"
                 % (esc(fmt(ig.represented_area, 10)), esc(fmt(ig.valid_area, 10)), esc(pct(frac, 3))))
    parts.append('<p class="note">Labels: %s.</p>' % "; ".join(
        "%s: %s" % (esc(s.value), esc(STATUS_MEANING[s])) for s in Status))
    return "".join(parts)


def maps_section(a):
    from .render import VIEW_TITLES, render_class_map, render_density_map
    f = a.fields
    if f is None or len(getattr(f, "triangles", [])) == 0:
        return "<h2>Maps</h2><p>No distributed fields in this assessment (assessed without fields).</p>"
    fr = [a.validity[m].value for m in METRICS[3:]]
    dens = render_density_map(f, k_f=a.thresholds.k_f, title="developability density log10(|K| L_ref^2)")
    cls = render_class_map(f, title="curvature classes (h_f = %g, k_f = %g)" % (a.thresholds.h_f, a.thresholds.k_f),
                           fractions=fr)
    carrier = ("exact BRep samples at the nodes of a display-only tessellation (not used in the integrals)"
               if f.kind == "brep-display" else "mesh vertices")
    return ("<h2>Maps</h2><p class=\"note\">Samples: %s, %d points, %d triangles. Fixed orthographic views: %s. "
            "Each triangle is one colour (mean of its vertices; class: the class shared by most of its "
            "vertices); grey where a vertex is an invalid sample. Density display range: log10(k_f) to the "
            "99.5th percentile of the positive samples, saturated outside (display only).</p>%s%s"
            % (esc(carrier), len(f.points), len(f.triangles), esc("; ".join(VIEW_TITLES.values())),
               png_img(dens, "developability density map"), png_img(cls, "curvature class map")))


def faces_section(a):
    rows = (a.provenance or {}).get("faces")
    if not rows:
        return ""
    out = []
    for r in rows:
        ac = r.get("a_C") or {}
        out.append([r.get("face"), r.get("surface_type") or r.get("evaluation"), fmt(r.get("area"), 7),
                    pct(r.get("area_share"), 2), pct(r.get("K_share"), 2), fmt(r.get("I_D"), 6),
                    " / ".join(fmt(ac.get(n), 4) for n in CLASS_NAMES),
                    badge(r.get("status", "-")), fmt(r.get("trimmed")), fmt(r.get("depth_reached"))])
    return ("<h2>Faces</h2>" + table(["face", "surface", "area", "area share %", "|K| share %", "I_D",
                                     "a_C (flat/single/elliptic/saddle)", "status", "trimmed", "depth"],
                                    out, left=(1, 6)))


#: Mesh-quality items shown in the visible table (the full record follows, collapsed).
QUALITY_HEADLINE = ("advisory", "reasons", "counts", "connected_components", "watertight", "boundary",
                    "sliver_fraction", "low_quality_fraction", "inconsistent_winding_edges")


def quality_table(q):
    """Headline mesh-quality table and the full record in a collapsed block."""
    head = {k: q[k] for k in QUALITY_HEADLINE if k in q}
    return (kv_table(head) if head else "") + \
        "<details><summary>full mesh-quality record</summary>%s</details>" % kv_table(q)


def quality_section(a):
    from .refinement import mesh_quality_of
    q = mesh_quality_of(a)
    if not q:
        return ""
    return "<h2>Mesh quality</h2>" + quality_table(q)


def provenance_section(a):
    prov = {k: v for k, v in (a.provenance or {}).items() if k not in ("faces", "quality", "mesh_quality")}
    parts = ["<h2>Provenance</h2>", "<h3>Input</h3>", kv_table(a.input)]
    if prov:
        parts += ["<details><summary>representation provenance</summary>", kv_table(prov), "</details>"]
    if a.options:
        parts += ["<h3>Options</h3>", kv_table(a.options)]
    if a.timings:
        parts += ["<details><summary>timings [s]</summary>", kv_table(a.timings), "</details>"]
    if a.warnings:
        parts += ["<h3>Warnings</h3><ul>"] + ["<li>%s</li>" % esc(w) for w in a.warnings] + ["</ul>"]
    return "".join(parts)


# ---------------------------------------------------------------------------------------------
# study sections


def _pair(rec, q):
    x = rec.get(q)
    if x is None:
        return "-"
    return " / ".join(pct(x.get(p)) for p in ("consistent", "alternating") if p in x)


def _null_reasons(rec):
    """'key: reason' text of a record's null values (one line per distinct reason)."""
    by = {}
    for k, v in (rec.get("reasons") or {}).items():
        by.setdefault(v, []).append(k)
    return "; ".join("%s: %s" % (", ".join(ks), v) for v, ks in by.items())


def headline_rows(s):
    """Rows of the headline and largest-|K| faces of a same-face document."""
    rows = []
    for label, rec in (("headline: " + (s.get("headline_face") or {}).get("rule", "largest area"),
                        s.get("headline_face")),
                       ("largest |K| share (%s)" % ((s.get("largest_K_face") or {}).get("abs_K_share_source") or "-"),
                        s.get("largest_K_face"))):
        rec = rec or {}
        if rec.get("face") is None:
            rows.append([label, "-", "", "", "", "", _null_reasons(rec)])
            continue
        note = rec.get("diagnosis") or ""
        if rec.get("passed_over"):
            note = "larger faces passed over: %s. %s" % (
                "; ".join("%s (%s)" % (f["face"], f["reason"]) for f in rec["passed_over"]), note)
        nulls = "; ".join(_null_reasons(rec.get(q) or {}) for q in ("eps_H", "eps_K")
                          if (rec.get(q) or {}).get("reasons"))
        rows.append([label, rec["face"], pct(rec.get("area_share"), 1), pct(rec.get("abs_K_share"), 1),
                     _pair(rec, "eps_H"), _pair(rec, "eps_K"), (nulls + " " if nulls else "") + note])
    return rows


def sameface_section(s):
    from .render import render_sameface_errors
    parts = ["<h2>Same-face BRep-to-mesh curvature recovery</h2>",
             '<p class="note">Structured grids over an inset parameter rectangle (inset %s of each range), '
             "vertices at S(u, v), grid lines on the face's C0 knot lines (creases); relative L2 errors "
             "of H and K with the consistent P1 mass matrix on the common two-ring "
             "strict-interior mask, crease rows counted as boundary; one global sign for H. "
             "'smooth': also without the vertices whose two-ring crosses a knot line below C2 "
             "(where the BRep H, K jump). The headline face is the face of largest area; the face "
             "with the largest share of the integral of |K| is named beside it.</p>" % esc(fmt(s["settings"]["inset"]))]
    parts.append("<h3>Headline (relative L2 error in % at the finest level, consistent / alternating mesh)</h3>")
    parts.append(table(["face", "number", "area share %", "|K| share %", "eps_H %", "eps_K %", "diagnosis"],
                       headline_rows(s), left=(0, 6)))
    summary = []
    for f in s["faces"]:
        if f.get("skipped"):
            summary.append([f["face"], "skipped: " + f["skipped"], "", "", "", "", pct(f.get("abs_K_share"), 1), ""])
            continue
        recs = [r for r in f["levels"] if not r.get("unavailable")]
        fine = max(r["panels"] for r in recs)
        by = {r["pattern"]: r for r in recs if r["panels"] == fine}
        c, al = by.get("consistent", {}), by.get("alternating", {})
        nulls = "; ".join(sorted({_null_reasons(r) for r in (c, al) if r.get("reasons")}))
        summary.append([f["face"], f.get("surface_kind"), pct(c.get("eps_H")), pct(al.get("eps_H")),
                        pct(c.get("eps_K")), pct(al.get("eps_K")), pct(f.get("abs_K_share"), 1),
                        (nulls + ". " if nulls else "") + f["diagnosis"]["text"]])
    parts.append("<h3>Finest level (relative L2 error in %, laid out as the paper's same-face verification table)</h3>")
    parts.append(table(["face", "surface", "H consistent %", "H alternating %", "K consistent %",
                        "K alternating %", "|K| share %", "diagnosis (null values: reason)"], summary, left=(1, 7)))
    for f in s["faces"]:
        if f.get("skipped"):
            continue
        parts.append("<h3>Face %s (%s, %s)</h3>" % (esc(f["face"]), esc(f.get("surface_kind")), esc(f.get("method"))))
        parts.append('<p class="note">parameter rectangle u in [%s, %s], v in [%s, %s]</p>'
                     % tuple(esc(fmt(x)) for x in f["rect"]))
        rows = [[r["panels"], r["pattern"], pct(r["eps_H"]), pct(r["eps_K"]), pct(r.get("eps_H_smooth")),
                 pct(r.get("eps_K_smooth")), fmt(r["n_retained"]), fmt(r.get("H_sign")),
                 fmt(r.get("median_abs_error_H"), 3), fmt(r.get("p95_abs_error_H"), 3),
                 fmt(r.get("median_abs_error_K"), 3), fmt(r.get("p95_abs_error_K"), 3),
                 ("H " if r.get("H_reference_negligible") else "") + ("K" if r.get("K_reference_negligible") else ""),
                 _null_reasons(r)]
                for r in f["levels"]]
        parts.append(table(["panels", "pattern", "eps_H %", "eps_K %", "smooth eps_H %", "smooth eps_K %",
                            "retained", "H sign", "median |dH|", "p95 |dH|", "median |dK|", "p95 |dK|",
                            "quasi-zero ref.", "null values: reason"], rows, left=(1, 13)))
        if f["ratios"]:
            parts.append(table(["pattern", "eps_H ratio %s/%s" % (f["ratios"][0]["fine"], f["ratios"][0]["coarse"]),
                                "eps_K ratio", "null values: reason"],
                               [[r["pattern"], fmt(r["eps_H_ratio"], 4), fmt(r["eps_K_ratio"], 4), _null_reasons(r)]
                                for r in f["ratios"]], left=(0, 3)))
        parts.append('<p class="note">Diagnosis: %s</p>' % esc(f["diagnosis"]["text"]))
    if any(f.get("levels") for f in s["faces"]):
        parts.append(png_img(render_sameface_errors(s), "same-face errors against grid level"))
    return "".join(parts)


def _sig_cells(r):
    ac = r["a_C"]
    return [fmt(r["I_D"], 6), "%s / %s" % (fmt(r["I_D_plus"], 6), fmt(r["I_D_minus"], 6))] + \
        [fmt(ac.get(n), 5) for n in CLASS_NAMES]


def refinement_section(s):
    rows = []
    for r in s["levels"]:
        rc = r.get("relative_change") or {}
        rows.append([r["name"], fmt(r.get("linear_deflection")), fmt(r.get("angular_deflection")),
                     fmt(r.get("n_triangles"))] + _sig_cells(r) +
                    [pct(rc.get("I_D"), 2), pct(rc.get("I_D_plus"), 2), pct(rc.get("I_D_minus"), 2),
                     fmt(r.get("d1"), 4), badge(r["status"]["I_D"])])
    parts = ["<h2>Mesh-resolution sensitivity</h2>",
             '<p class="note">%s; L<sub>ref</sub> = %s; changes relative to the finest level; d1 = the sum over '
             "the four classes of the change of their area fractions.</p>" % (esc(s["settings"].get("ladder")), esc(fmt(s.get("lref"), 8))),
             table(["level", "linear defl./L_ref", "angular [rad]", "triangles", "I_D", "I_D+ / I_D-",
                    "flat", "single", "elliptic", "saddle", "dI_D %", "dI_D+ %", "dI_D- %", "d1", "I_D status"],
                   rows, left=(0,))]
    succ = [[x["from"], x["to"], pct(x["relative_change_I_D"], 2), fmt(x["d1"], 4)] for x in s.get("successive", [])]
    if succ:
        parts.append(table(["from", "to", "dI_D % (vs 'to')", "d1"], succ, left=(0, 1)))
    for r in s["levels"]:
        if r.get("quality"):
            parts.append("<details><summary>mesh quality: %s (%s)</summary>%s</details>"
                         % (esc(r["name"]), esc(r["quality"].get("advisory")), kv_table(r["quality"])))
    return "".join(parts)


def representation_section(s):
    rows = [[r["representation"]] + _sig_cells(r) + [pct(r.get("valid_area_fraction"), 3), badge(r["status"]["I_D"])]
            for r in s["rows"]]
    d = s["delta_percent"]
    red = s["class_redistribution"]
    return ("<h2>Representation: native BRep against triangle mesh</h2>"
            '<p class="note">Mesh: %s; L<sub>ref</sub> = %s. Laid out as the table of public-hull signatures in the paper.</p>'
            % (esc(", ".join("%s=%s" % (k, fmt(v)) for k, v in s["mesh"].items())), esc(fmt(s["lref"], 8)))
            + table(["representation", "I_D", "I_D+ / I_D-", "flat", "single", "elliptic", "saddle",
                     "valid area %", "I_D status"], rows, left=(0,))
            + table(["Delta I_D %", "Delta I_D+ %", "Delta I_D- %", "d1"] + ["Delta a_%s" % n for n in CLASS_NAMES],
                    [[fmt(d["I_D"], 4), fmt(d["I_D_plus"], 4), fmt(d["I_D_minus"], 4), fmt(s["d1"], 4)]
                     + [fmt(red[n], 4) for n in CLASS_NAMES]]))


def with_status(value, status, digits):
    """A table cell: the value and its validity badge (the status alone when no value)."""
    cell = esc(fmt(value, digits))
    return Raw(cell + (" " + badge(status).html if status else ""))


def thresholds_section(s):
    def cells(r):
        st = r.get("status") or {}
        return ([fmt(r["h_f"])] + [with_status(r[q], st.get(q), 8) for q in ("I_D", "I_D_plus", "I_D_minus")]
                + [with_status(r["a_C"].get(n), st.get("a_" + n), 5) for n in CLASS_NAMES]
                + [fmt(r["double_curved"], 5)])
    ch = s.get("double_curved_change") or {}
    return ("<h2>Threshold study</h2>"
            + table(["h_f = k_f", "I_D", "I_D+", "I_D-", "flat", "single", "elliptic", "saddle", "double-curved"],
                    [cells(r) for r in s["rows"]])
            + "<p>Largest relative spread of I_D, I_D+, I_D- over the tolerances: %s (threshold independent by "
              "definition). Double-curved fraction from h_f = %s to %s: change %s (absolute), %s %% (relative).</p>"
            % (esc(fmt(s.get("max_I_D_spread"), 3)), esc(fmt(ch.get("from"))), esc(fmt(ch.get("to"))),
               esc(fmt(ch.get("absolute"), 4)), esc(pct(ch.get("relative"), 3))))


STUDY_SECTIONS = {"sameface": sameface_section, "refinement": refinement_section,
                  "representation": representation_section, "thresholds": thresholds_section}


def study_section(study):
    kind = study.get("study")
    if kind not in STUDY_SECTIONS:
        raise InputError("unknown study %r in the report (known: %s)" % (kind, ", ".join(STUDY_SECTIONS)))
    return STUDY_SECTIONS[kind](study)


# ---------------------------------------------------------------------------------------------
# the page


def report_html(assessment=None, studies=None, title=None):
    """The report as one HTML string (see module docstring); assessment and/or studies."""
    if isinstance(studies, dict):
        studies = [studies]
    studies = list(studies or [])
    if assessment is None and not studies:
        raise InputError("a report needs an assessment or at least one study")
    name = None
    if assessment is not None:
        name = assessment.input.get("path") or assessment.input.get("name")
    elif studies:
        inp = studies[0].get("input") or {}
        name = inp.get("path") or inp.get("name")
    title = title or "HullProd report: %s" % (os.path.basename(name) if name else "hull")
    body = ["<h1>%s</h1>" % esc(title),
            '<p class="note">Generated %s by hullprod_wb. Geometry-based producibility signature '
            "(I_D, I_D+, I_D-, a_C) with metric-specific validity; no composite score.</p>"
            % esc(datetime.datetime.now().isoformat(timespec="seconds"))]
    if assessment is not None:
        body.append('<p>Input: %s (%s)</p>' % (esc(name), esc(assessment.input.get("representation"))))
        body += [signature_section(assessment), maps_section(assessment), faces_section(assessment),
                 quality_section(assessment), provenance_section(assessment)]
    for s in studies:
        body.append(study_section(s))
    return ('<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><title>%s</title><style>%s</style>'
            "</head><body>%s</body></html>\n" % (esc(title), CSS, "\n".join(body)))


def write_report(assessment, path, studies=None, title=None):
    """Write the HTML report of an assessment (may be None) and optional studies to path.

    path: a file name, or an existing folder (then path/report.html). studies: a study dict
    or a list of them (as returned by the study functions); title: the page's heading
    (default: after the input's file or object name). Returns the file path.
    """
    if os.path.isdir(path):
        path = os.path.join(path, "report.html")
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    text = report_html(assessment, studies, title)
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(text)
    return path
