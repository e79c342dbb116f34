"""Regenerate the study tables of docs/verification_studies.md.

    /usr/bin/python3 tools/study_tables.py [--write]

Runs the four studies with their default settings on the analytic controls and on the
shared hulls in ../shared/hulls/brep that are present (same-face; mesh-resolution ladder;
native BRep against its tessellation; thresholds) and prints the Markdown tables; with
--write each table set replaces the text between its markers <!-- NAME-tables:begin -->
and <!-- NAME-tables:end --> (NAME = sameface, refinement, representation, thresholds) of
docs/verification_studies.md. L_ref: the hulls' L_pp (DTMB 5415 5720 mm, KVLCC2 5520 mm,
the WaveBEM Wigley 2500 mm), 1 for the unit half-Wigley controls.
"""
import os
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.join(ROOT, "tests"))
DOC = os.path.join(ROOT, "docs", "verification_studies.md")
HULLS = os.path.normpath(os.path.join(ROOT, "..", "shared", "hulls", "brep"))
MARKERS = "<!-- %s-tables:begin -->", "<!-- %s-tables:end -->"
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
    from hullprod_wb.examples import analytic_shapes
    from hullprod_wb.examples.builtin import half_wigley_shape
    from hullprod_wb.studies import sameface_study
    from test_studies import creased_face
    rows = ["| control (48 x 48, c / a) | eps_H [%] | eps_K [%] | ratio 48/12 H | ratio 48/12 K |",
            "|---|---|---|---|---|"]
    for label, shape in (("saddle (Bezier)", analytic_shapes.saddle_face()), ("torus face", analytic_shapes.torus_shape()),
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
    out = ["Generated by `/usr/bin/python3 tools/study_tables.py --write` (default settings: levels "
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


#: (file, label, L_ref, faces) of the hulls of the BRep-based studies.
BREP_HULLS = {"dtmb": ("dtmb5415_half_overture.igs", "DTMB 5415", 5720.0),
              "kvlcc2": ("kvlcc2_half_overture.igs", "KVLCC2", 5520.0),
              "wigley": ("wigley_half_wavebem.iges", "Wigley WaveBEM", 2500.0)}


def pc(x):
    return "-" if x is None else "%+.2f" % (100.0 * x)


def f6(x, digits=6):
    return "-" if x is None else "%.*g" % (digits, x)


def classes(a_c):
    return " | ".join(f6(a_c.get(n), 4) for n in ("flat", "single", "elliptic", "saddle"))


def hull_path(key):
    path = os.path.join(HULLS, BREP_HULLS[key][0])
    return path if os.path.isfile(path) else None


def generated(name):
    return "Generated by `/usr/bin/python3 tools/study_tables.py --write` (%s)." % name


def refinement_tables():
    from hullprod_wb.examples.builtin import half_wigley_shape
    from hullprod_wb.studies import refinement_study
    rows = [generated("ladder 0.0035 / 0.3, 0.00175 / 0.25, 0.000875 / 0.2 of L_ref / rad; all faces"), "",
            "| hull (L_ref) | level | triangles | I_D | dI_D vs fine [%] | dI_D+ [%] | dI_D- [%] | d1 vs fine |",
            "|---|---|---|---|---|---|---|---|"]
    cases = [("%s all faces (%g mm)" % (BREP_HULLS[k][1], BREP_HULLS[k][2]), hull_path(k), BREP_HULLS[k][2])
             for k in ("dtmb", "kvlcc2") if hull_path(k)]
    cases.append(("half-Wigley Bezier (1)", half_wigley_shape(), 1.0))
    for label, source, lref in cases:
        doc = refinement_study(source=source, lref=lref)
        for i, r in enumerate(doc["levels"]):
            rc = r["relative_change"]
            rows.append("| %s | %s | %s | %s | %s | %s | %s | %s |" % (
                label if i == 0 else "", r["name"], r["n_triangles"], f6(r["I_D"]), pc(rc["I_D"]),
                pc(rc["I_D_plus"]), pc(rc["I_D_minus"]), f6(r["d1"], 4)))
    return rows


def representation_tables():
    from hullprod_wb.studies import representation_study
    rows = [generated("mesh: the tessellation at 0.000875 L_ref, 0.2 rad"), "",
            "| hull (L_ref) | representation | triangles | I_D | Delta I_D [%] | I_D+ / I_D- | flat | single | "
            "elliptic | saddle | valid area [%] | I_D status | d1 |", "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    cases = [("wigley", None), ("dtmb", [1, 2]), ("kvlcc2", None)]
    for key, faces in cases:
        path = hull_path(key)
        if not path:
            continue
        t = time.perf_counter()
        doc = representation_study(path, lref=BREP_HULLS[key][2], faces=faces)
        dt = time.perf_counter() - t
        label = "%s%s (%g mm; study %.1f s)" % (BREP_HULLS[key][1], " faces 1+2" if faces else "",
                                               BREP_HULLS[key][2], dt)
        brep, mesh = doc["rows"]
        for i, r in enumerate((brep, mesh)):
            rows.append("| %s | %s | %s | %s | %s | %s / %s | %s | %s | %s | %s |" % (
                label if i == 0 else "", r["representation"], "-" if i == 0 else doc["mesh"]["n_triangles"],
                f6(r["I_D"]), "-" if i == 0 else "%+.2f" % doc["delta_percent"]["I_D"], f6(r["I_D_plus"]),
                f6(r["I_D_minus"]), classes(r["a_C"]), p(r.get("valid_area_fraction"), 2), r["status"]["I_D"],
                "-" if i == 0 else f6(doc["d1"], 4)))
    return rows


def threshold_tables():
    from hullprod_wb.examples.analytic_meshes import half_wigley_mesh
    from hullprod_wb.studies import threshold_study
    rows = [generated("h_f = k_f in 1e-5, 1e-4, 1e-3"), "",
            "| hull | representation | h_f = k_f | I_D | flat | single | elliptic | saddle | double-curved | "
            "I_D spread |", "|---|---|---|---|---|---|---|---|---|---|"]
    cases = []
    if hull_path("dtmb"):
        cases.append(("DTMB 5415 faces 1+2 (5720 mm)", hull_path("dtmb"), 5720.0, [1, 2]))
    if hull_path("wigley"):
        cases.append(("Wigley (WaveBEM, 2500 mm)", hull_path("wigley"), 2500.0, None))
    cases.append(("half-Wigley analytic mesh 64 x 16 (1)", half_wigley_mesh(64, 16), 1.0, None))
    for label, source, lref, faces in cases:
        doc = threshold_study(source, lref=lref, faces=faces)
        for i, r in enumerate(doc["rows"]):
            rows.append("| %s | %s | %g | %s | %s | %s | %s |" % (
                label if i == 0 else "", doc["representation"] if i == 0 else "", r["h_f"], f6(r["I_D"], 10),
                classes(r["a_C"]), f6(r["double_curved"], 4), f6(doc["max_I_D_spread"], 3) if i == 0 else ""))
    return rows


SECTIONS = {"sameface": lambda: tables().rstrip("\n").split("\n"), "refinement": refinement_tables,
            "representation": representation_tables, "thresholds": threshold_tables}


def main(argv):
    texts = {name: "\n".join(make()).rstrip() + "\n" for name, make in SECTIONS.items()}
    if "--write" not in argv:
        for name, text in texts.items():
            sys.stdout.write("## %s\n\n%s\n" % (name, text))
        return 0
    doc = open(DOC, encoding="utf-8").read()
    for name, text in texts.items():
        begin, end = MARKERS[0] % name, MARKERS[1] % name
        a, b = doc.index(begin) + len(begin), doc.index(end)
        doc = doc[:a] + "\n" + text + doc[b:]
    with open(DOC, "w", encoding="utf-8") as fh:
        fh.write(doc)
    print("wrote the study tables into %s" % DOC)
    return 0


if __name__ == "__main__":
    from hullprod_wb.freecad_env import import_freecad
    import_freecad()
    sys.exit(main(sys.argv[1:]))
