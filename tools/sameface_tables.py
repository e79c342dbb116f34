"""Regenerate the same-face tables of docs/verification_studies.md.

    /usr/bin/python3 tools/sameface_tables.py [--write]

Runs the same-face study (default settings) on the analytic controls and on the shared hulls
in ../shared/hulls/brep that are present, and prints the Markdown tables; with --write they
replace the text between the markers <!-- sameface-tables:begin --> and
<!-- sameface-tables:end --> of docs/verification_studies.md.
"""
import os
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.join(ROOT, "tests"))
DOC = os.path.join(ROOT, "docs", "verification_studies.md")
HULLS = os.path.normpath(os.path.join(ROOT, "..", "shared", "hulls", "brep"))
BEGIN, END = "<!-- sameface-tables:begin -->", "<!-- sameface-tables:end -->"
#: (file, label) of the shared hulls tabulated.
SHARED = [("dtmb5415_half_overture.igs", "DTMB 5415 (Overture)"), ("kvlcc2_half_overture.igs", "KVLCC2 (Overture)"),
          ("kcs_full_closed_ohp.iges", "KCS closed (OHP)"), ("series60_half_wavebem.iges", "Series 60 (WaveBEM)"),
          ("wigley_half_wavebem.iges", "Wigley (WaveBEM)")]


def p(x, digits=2):
    """100 x with `digits` decimals (two significant digits below the last decimal)."""
    if x is None:
        return "-"
    return "%.*f" % (digits, 100.0 * x) if abs(100.0 * x) >= 10.0 ** -digits or x == 0 else "%.2g" % (100.0 * x)


def g(x):
    return "-" if x is None else "%.3g" % x


def pair(by, n, q):
    c, a = by.get((n, "consistent"), {}), by.get((n, "alternating"), {})
    return "%s / %s" % (p(c.get(q)), p(a.get(q)))


def figure_pair(rec, q):
    x = (rec or {}).get(q) or {}
    return "%s / %s" % (p(x.get("consistent")), p(x.get("alternating")))


def null_reasons(face):
    seen = []
    for r in face.get("levels", []):
        for k, v in (r.get("reasons") or {}).items():
            if v not in seen:
                seen.append(v)
    return seen


def face_rows(doc):
    levels = doc["settings"]["levels"]
    head = ["face", "area share", "abs K share", "region", "creases"]
    head += ["%d: %s c/a" % (n, q) for n in levels for q in ("H", "K")]
    head += ["ratio %d/%d H c/a" % (levels[-1], levels[0]), "ratio K c/a", "diagnosis; null values: reason"]
    rows = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for f in doc["faces"]:
        if f.get("skipped"):
            rows.append("| %s | %s | %s | skipped | | %s| %s |" % (
                f["face"], p(f.get("area_share"), 1), p(f.get("abs_K_share"), 1),
                "| " * (2 * len(levels) + 2), f["skipped"]))
            continue
        by = {(r["panels"], r["pattern"]): r for r in f["levels"]}
        cr = ", ".join(["u = %g" % x for x in f["creases"]["u"]] + ["v = %g" % x for x in f["creases"]["v"]]) or "-"
        ratios = {r["pattern"]: r for r in f["ratios"]}
        rat = ["%s / %s" % (g(ratios.get("consistent", {}).get(k)), g(ratios.get("alternating", {}).get(k)))
               for k in ("eps_H_ratio", "eps_K_ratio")]
        notes = f["diagnosis"]["text"]
        nulls = null_reasons(f)
        if nulls:
            notes += "; null: " + "; ".join(nulls)
        region = "trimmed" if f.get("trimmed") else "untrimmed"
        cells = [str(f["face"]), p(f.get("area_share"), 1), p(f.get("abs_K_share"), 1), region, cr]
        cells += [pair(by, n, "eps_" + q) for n in levels for q in ("H", "K")]
        rows.append("| " + " | ".join(cells + rat + [notes.replace("|", "/")]) + " |")
    return rows


def summary_row(label, nfaces, doc, seconds):
    h, k = doc["headline_face"], doc["largest_K_face"]
    passed = ", ".join(str(x["face"]) for x in h.get("passed_over", [])) or "-"
    return "| %s | %d | %s (%s of the area) | %s | %s | %s (%s of int abs(K) dA) | %s | %s | %s | %.1f |" % (
        label, nfaces, h["face"], p(h.get("area_share"), 1) + " %", figure_pair(h, "eps_H"), figure_pair(h, "eps_K"),
        k["face"], p(k.get("abs_K_share"), 1) + " %", figure_pair(k, "eps_H"), figure_pair(k, "eps_K"), passed,
        seconds)


def controls():
    import brep_shapes
    from hullprod_wb.examples.builtin import half_wigley_shape
    from hullprod_wb.studies import sameface_study
    from test_studies import creased_face
    rows = ["| control (48 x 48, c / a) | eps_H [%] | eps_K [%] | ratio 48/12 H | ratio 48/12 K |",
            "|---|---|---|---|---|"]
    for label, shape in (("saddle (Bezier)", brep_shapes.saddle_face()), ("torus face", brep_shapes.torus_shape()),
                         ("half-Wigley (Bezier)", half_wigley_shape()),
                         ("creased cubic B-spline (crease on a grid line)", creased_face())):
        f = sameface_study(shape)["faces"][0]
        by = {(r["panels"], r["pattern"]): r for r in f["levels"]}
        ratios = {r["pattern"]: r for r in f["ratios"]}
        rows.append("| %s | %s | %s | %s | %s |" % (
            label, pair(by, 48, "eps_H"), pair(by, 48, "eps_K"),
            " / ".join(g(ratios[x]["eps_H_ratio"]) for x in ("consistent", "alternating")),
            " / ".join(g(ratios[x]["eps_K_ratio"]) for x in ("consistent", "alternating"))))
    return rows


def tables():
    from hullprod_wb.studies import sameface_study
    out = ["Generated by `/usr/bin/python3 tools/sameface_tables.py --write` (default settings: levels "
           "12, 24, 48, both patterns, 5 % inset, creases on grid lines; 100 eps, consistent / alternating).", "",
           "Analytic controls:", ""] + controls() + [""]
    summary = ["| hull | faces | headline face (largest area) | 48: H c/a | 48: K c/a | largest abs(K) share face | "
               "48: H c/a | 48: K c/a | larger faces passed over (no curvature reference) | study time [s] |",
               "|---|---|---|---|---|---|---|---|---|---|"]
    per_hull = []
    for name, label in SHARED:
        path = os.path.join(HULLS, name)
        if not os.path.isfile(path):
            continue
        t = time.perf_counter()
        doc = sameface_study(path)
        dt = time.perf_counter() - t
        summary.append(summary_row(label, len(doc["faces"]), doc, dt))
        per_hull += ["**%s** (%s)" % (name, label), ""] + face_rows(doc) + [""]
        if name.startswith("dtmb5415"):
            uni = sameface_study(path, align_creases=False)
            per_hull += ["**%s** on the uniform grid (`align_creases=False`, crease rows not masked), for "
                         "comparison" % name, ""] + face_rows(uni) + [""]
    out += ["Shared hulls (|K| shares: the study's midpoint estimate on the trimmed-domain raster; study "
            "times on a shared 2-core machine, single runs, noisy):", ""] + summary + [""] + per_hull
    return "\n".join(out).rstrip() + "\n"


def main(argv):
    text = tables()
    if "--write" not in argv:
        sys.stdout.write(text)
        return 0
    doc = open(DOC, encoding="utf-8").read()
    a, b = doc.index(BEGIN) + len(BEGIN), doc.index(END)
    with open(DOC, "w", encoding="utf-8") as fh:
        fh.write(doc[:a] + "\n" + text + doc[b:])
    print("wrote the same-face tables into %s" % DOC)
    return 0


if __name__ == "__main__":
    from hullprod_wb.freecad_env import import_freecad
    import_freecad()
    sys.exit(main(sys.argv[1:]))
