"""`hullprod study sameface|refinement|representation|thresholds INPUT [options]`.

Each study prints a table (or with --json one JSON document on stdout), writes
DIR/study_<name>.json with --out DIR, and DIR/report.html with --report (DIR defaults to
out/study_<name>). Progress goes to stderr.
"""
import os
import sys

from ..core.errors import InputError
from ..core.progress import StderrProgress, null_progress
from ..core.writers import dumps, prepare_output_dir, write_json


def _floats(text, what):
    try:
        vals = [float(t) for t in str(text).replace(" ", "").split(",") if t]
    except ValueError:
        raise InputError("%s takes numbers separated by commas, got %r" % (what, text)) from None
    if not vals:
        raise InputError("%s needs at least one number" % what)
    return vals


def _ints(text, what):
    vals = _floats(text, what)
    if any(v != int(v) or v < 1 for v in vals):
        raise InputError("%s takes positive whole numbers, got %r" % (what, text))
    return [int(v) for v in vals]


def _words(text, what, allowed):
    vals = [t for t in str(text).replace(" ", "").split(",") if t]
    bad = [v for v in vals if v not in allowed]
    if bad or not vals:
        raise InputError("%s: unknown value(s) %s (choose from %s)" % (what, ",".join(bad) or "none", ", ".join(allowed)))
    return vals


def add_parser(subparsers):
    """Register the `study` command and its four sub-commands."""
    from ..cli import add_common_options
    from .refinement import ANGULAR_DEFLECTIONS, LINEAR_DEFLECTIONS
    from .sameface import DEFAULT_INSET, PATTERNS, SAMEFACE_LEVELS
    from .thresholds import DEFAULT_TOLERANCES

    st = subparsers.add_parser("study", help="verification studies (same-face, refinement, representation, thresholds)")
    sub = st.add_subparsers(dest="study", metavar="STUDY")
    sub.required = True

    def common(p, name):
        add_common_options(p)
        p.add_argument("--json", action="store_true", help="print only the study's JSON document on stdout")
        p.add_argument("--out", default=None, help="write study_%s.json (and report.html) into this folder" % name)
        p.add_argument("--overwrite", action="store_true", help="allow writing into a non-empty --out folder")
        p.add_argument("--report", action="store_true",
                       help="write report.html into --out (default folder out/study_%s)" % name)
        p.add_argument("--quiet", action="store_true", help="no progress messages")

    s = sub.add_parser("sameface", help="same-face BRep-to-mesh curvature recovery (relative L2 error of H and K)")
    s.add_argument("input", help="BRep file (.igs .iges .step .stp .brep)")
    common(s, "sameface")
    s.add_argument("--levels", default=",".join(map(str, SAMEFACE_LEVELS)), help="panels per direction (default 12,24,48)")
    s.add_argument("--patterns", default=",".join(PATTERNS), help="diagonal patterns (default consistent,alternating)")
    s.add_argument("--inset", type=float, default=DEFAULT_INSET,
                   help="inset of the parameter rectangle per side, fraction of each range (default 0.05)")
    s.add_argument("--shares", action="store_true",
                   help="also assess the BRep to list each face's share of the integral of |K|")
    s.set_defaults(func=run_sameface)

    r = sub.add_parser("refinement", help="mesh-resolution sensitivity of a mesh ladder (class-fraction change d1)")
    r.add_argument("input", nargs="+", help="one BRep (tessellated into the ladder) or several meshes, coarse to fine")
    common(r, "refinement")
    r.add_argument("--linear", default=",".join(map(str, LINEAR_DEFLECTIONS)),
                   help="linear deflections as fractions of L_ref (default 0.0035,0.00175,0.000875)")
    r.add_argument("--angular", default=",".join(map(str, ANGULAR_DEFLECTIONS)),
                   help="angular deflections in rad (default 0.3,0.25,0.2)")
    r.set_defaults(func=run_refinement)

    p = sub.add_parser("representation", help="native BRep against a triangulated realization")
    p.add_argument("input", help="BRep file")
    common(p, "representation")
    p.add_argument("--mesh", default=None, help="mesh of the same hull (default: tessellation at the finest ladder level)")
    p.add_argument("--mesh-lref", type=float, default=None, help="L_ref in the mesh's units if they differ")
    p.add_argument("--linear", type=float, default=LINEAR_DEFLECTIONS[-1], help="linear deflection / L_ref (default 0.000875)")
    p.add_argument("--angular", type=float, default=ANGULAR_DEFLECTIONS[-1], help="angular deflection in rad (default 0.2)")
    p.set_defaults(func=run_representation)

    t = sub.add_parser("thresholds", help="signature under several tolerances h_f = k_f")
    t.add_argument("input", help="hull file (BRep or mesh)")
    common(t, "thresholds")
    t.add_argument("--tolerances", default=",".join("%g" % x for x in DEFAULT_TOLERANCES),
                   help="h_f = k_f values (default 1e-5,1e-4,1e-3)")
    t.set_defaults(func=run_thresholds)
    return st


def _p(x, digits=3):
    return "      -" if x is None else "%7.*f" % (digits, 100.0 * x)


def _g(x, digits=6):
    return "-" if x is None else "%.*g" % (digits, x)


def _figure_line(label, rec):
    """One line for the headline or largest-|K| face of a same-face document."""
    if rec is None or rec.get("face") is None:
        return "%s: none (%s)" % (label, "; ".join((rec or {}).get("reasons", {}).values()))
    def pair(q):
        x = rec.get(q)
        if x is None:
            return "-"
        return " / ".join(_p(x.get(p)).strip() for p in ("consistent", "alternating") if p in x)
    extra = ""
    if rec.get("passed_over"):
        extra = " (larger faces passed over: %s)" % ", ".join(
            "%s: %s" % (f["face"], f["reason"]) for f in rec["passed_over"])
    share = "" if rec.get("abs_K_share") is None else ", %.1f %% of int |K| dA" % (100 * rec["abs_K_share"])
    return "%s: face %s%s, %sx%s grid, error of H %s %%, of K %s %% (consistent / alternating mesh)%s" % (
        label, rec["face"], share, rec.get("panels"), rec.get("panels"), pair("eps_H"), pair("eps_K"), extra)


def sameface_summary(doc):
    """Lines of the plain-text same-face table: the headline and largest-|K| faces, every
    face's records with the reasons of its null values, its ratios and its diagnosis."""
    hl = doc.get("headline_face") or {}
    lines = [_figure_line("headline (%s)" % hl.get("rule", "largest area"), hl),
             _figure_line("largest |K| share (%s)" % ((doc.get("largest_K_face") or {}).get("abs_K_share_source")
                                                      or "-"), doc.get("largest_K_face")),
             "same-face curvature recovery, relative L2 error in %, two-ring mask with crease "
             "rows as boundary; 'smooth' also without the two-ring of knot lines below C2",
             "%5s %6s %-11s %8s %8s %8s %8s %6s" % ("face", "panels", "pattern", "eps_H%", "eps_K%",
                                                   "smoothH%", "smoothK%", "kept")]
    for f in doc["faces"]:
        if f.get("skipped"):
            lines.append("%5s skipped: %s" % (f["face"], f["skipped"]))
        for r in f["levels"]:
            kept = "-" if r["n_retained"] is None else "%d" % r["n_retained"]
            lines.append("%5s %6d %-11s %8s %8s %8s %8s %6s" % (
                f["face"], r["panels"], r["pattern"], _p(r["eps_H"]), _p(r["eps_K"]),
                _p(r.get("eps_H_smooth")), _p(r.get("eps_K_smooth")), kept))
            for why in sorted(set(r.get("reasons", {}).values())):
                keys = [k for k, v in r["reasons"].items() if v == why]
                lines.append("%5s %6s %-11s null %s: %s" % ("", "", "", ", ".join(keys), why))
        for q in f.get("ratios", []):
            lines.append("%5s ratio %d/%d %-11s eps_H %s eps_K %s" % (
                f["face"], q["fine"], q["coarse"], q["pattern"], _g(q["eps_H_ratio"], 4), _g(q["eps_K_ratio"], 4)))
            for k, why in sorted(q.get("reasons", {}).items()):
                lines.append("%5s %6s %-11s null %s: %s" % ("", "", "", k, why))
        if f.get("diagnosis"):
            lines.append("%5s diagnosis: %s" % (f["face"], f["diagnosis"]["text"]))
    return lines


def study_summary(doc):
    """Plain-text table of a study document."""
    kind = doc["study"]
    lines = []
    if kind == "sameface":
        lines += sameface_summary(doc)
    elif kind == "refinement":
        lines.append("mesh-resolution sensitivity, L_ref = %s; changes against the finest level" % _g(doc["lref"], 8))
        lines.append("%-10s %9s %12s %9s %9s %9s %8s" % ("level", "triangles", "I_D", "dI_D%", "dI_D+%", "dI_D-%", "d1"))
        for r in doc["levels"]:
            rc = r["relative_change"]
            lines.append("%-10s %9s %12s %9s %9s %9s %8s" % (r["name"], r.get("n_triangles"), _g(r["I_D"], 8),
                                                            _p(rc["I_D"], 2), _p(rc["I_D_plus"], 2),
                                                            _p(rc["I_D_minus"], 2), _g(r["d1"], 4)))
    elif kind == "representation":
        lines.append("representation comparison, L_ref = %s" % _g(doc["lref"], 8))
        lines.append("%-14s %12s %25s %8s %8s %8s %8s" % ("representation", "I_D", "I_D+ / I_D-", "flat", "single",
                                                         "elliptic", "saddle"))
        for r in doc["rows"]:
            ac = r["a_C"]
            lines.append("%-14s %12s %25s %8s %8s %8s %8s" % (
                r["representation"], _g(r["I_D"], 8), "%s / %s" % (_g(r["I_D_plus"]), _g(r["I_D_minus"])),
                _g(ac["flat"], 4), _g(ac["single"], 4), _g(ac["elliptic"], 4), _g(ac["saddle"], 4)))
        d = doc["delta_percent"]
        lines.append("Delta I_D %s %%, I_D+ %s %%, I_D- %s %%, d1 %s" % (_g(d["I_D"], 4), _g(d["I_D_plus"], 4),
                                                                    _g(d["I_D_minus"], 4), _g(doc["d1"], 4)))
    elif kind == "thresholds":
        lines.append("threshold study (%s), L_ref = %s" % (doc.get("representation"), _g(doc["lref"], 8)))
        lines.append("%10s %12s %8s %8s %8s %8s %8s  %s" % ("h_f=k_f", "I_D", "flat", "single", "elliptic", "saddle",
                                                           "double", "status I_D I_D+ I_D- flat single elliptic saddle"))
        for r in doc["rows"]:
            ac, st = r["a_C"], r.get("status") or {}
            statuses = " ".join(st.get(q, "-") for q in ("I_D", "I_D_plus", "I_D_minus", "a_flat", "a_single",
                                                          "a_elliptic", "a_saddle"))
            lines.append("%10g %12s %8s %8s %8s %8s %8s  %s" % (r["h_f"], _g(r["I_D"], 8), _g(ac["flat"], 4),
                                                               _g(ac["single"], 4), _g(ac["elliptic"], 4),
                                                               _g(ac["saddle"], 4), _g(r["double_curved"], 4),
                                                               statuses))
        lines.append("max relative spread of I_D, I_D+, I_D-: %s" % _g(doc["max_I_D_spread"], 3))
    return "\n".join(lines)


def _progress(args):
    return null_progress if args.quiet else StderrProgress()


def _quad(args):
    from ..cli import quadrature_options
    return quadrature_options(args)


def _finish(args, name, doc, assessment=None):
    """Print, save and report a study document; returns exit status 0."""
    out = args.out
    if args.report and not out:
        out = os.path.join("out", "study_%s" % name)
    if out:
        prepare_output_dir(out, args.overwrite or (not args.out))
        write_json(os.path.join(out, "study_%s.json" % name), doc)
    report_path = None
    if args.report:
        from .report import write_report
        report_path = write_report(assessment, os.path.join(out, "report.html"), studies=[doc])
    if args.json:
        sys.stdout.write(dumps(doc) + "\n")
    else:
        print(study_summary(doc))
        if out:
            print("wrote json       %s" % os.path.join(out, "study_%s.json" % name))
        if report_path:
            print("wrote report     %s" % report_path)
    return 0


def run_sameface(args):
    from ..cli import parse_faces
    from .sameface import PATTERNS, abs_K_shares, sameface_study
    faces = parse_faces(args.faces)
    shares = None
    if args.shares:
        from ..api import assess
        a = assess(args.input, lref=args.lref, h_f=args.hf, k_f=args.kf, backend="brep", faces=faces,
                   with_fields=False, progress=_progress(args), **_quad(args))
        shares = abs_K_shares(a)
    doc = sameface_study(args.input, faces=faces, levels=_ints(args.levels, "--levels"),
                         patterns=_words(args.patterns, "--patterns", PATTERNS), inset=args.inset,
                         progress=_progress(args), abs_K_share=shares)
    return _finish(args, "sameface", doc)


def run_refinement(args):
    from ..cli import parse_faces
    from ..core.inputs import describe_file
    from .refinement import refinement_study
    reps = [describe_file(p)["representation"] for p in args.input]
    kw = dict(lref=args.lref, h_f=args.hf, k_f=args.kf, progress=_progress(args))
    if reps == ["brep"]:
        doc = refinement_study(source=args.input[0], linear=_floats(args.linear, "--linear"),
                               angular=_floats(args.angular, "--angular"), faces=parse_faces(args.faces), **kw)
    elif all(r == "mesh" for r in reps) and len(reps) >= 2:
        if args.faces:
            raise InputError("--faces selects BRep faces; the inputs are meshes")
        doc = refinement_study(meshes=list(args.input), **kw)
    else:
        raise InputError("refinement takes one BRep file (tessellated into a ladder) or at least two mesh "
                         "files ordered coarse to fine; got %s" % ", ".join(reps))
    return _finish(args, "refinement", doc)


def run_representation(args):
    from ..cli import parse_faces
    from .representation import representation_study
    doc = representation_study(args.input, mesh=args.mesh, lref=args.lref, mesh_lref=args.mesh_lref,
                               h_f=args.hf, k_f=args.kf, faces=parse_faces(args.faces), linear=args.linear,
                               angular=args.angular, brep_options=_quad(args), progress=_progress(args))
    return _finish(args, "representation", doc)


def run_thresholds(args):
    from ..cli import parse_faces
    from .thresholds import threshold_study
    doc = threshold_study(args.input, tolerances=_floats(args.tolerances, "--tolerances"), lref=args.lref,
                          backend=args.backend, faces=parse_faces(args.faces), progress=_progress(args),
                          **_quad(args))
    return _finish(args, "thresholds", doc)
