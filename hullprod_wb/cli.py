"""Command line: ./hullprod analyze | example | study | batch.

Exit status 0 on success whatever the validity, 2 with a one-line reason for bad input.
With --json only the JSON document goes to stdout; progress and warnings go to stderr.
"""
import importlib
import os
import sys
import time

from .core.constants import DEFAULT_HF, DEFAULT_KF
from .core.errors import InputError
from .core.inputs import BREP_FORMATS, MESH_FORMATS, describe_file, start_sha256
from .core.progress import StderrProgress, null_progress

#: Modules that add further subcommands (each has add_parser(subparsers)); absent ones are skipped.
#: Commands registered by other modules: name -> (module with add_parser(subparsers), help).
#: A module is imported only when its command runs (its parser lists the sub-options);
#: otherwise the command is listed by name, so starting `analyze` stays light.
PLUGIN_COMMANDS = {
    "study": ("hullprod_wb.studies.cli",
              "verification studies (same-face, refinement, representation, thresholds)"),
    "batch": ("hullprod_wb.batch.cli",
              "signatures of many hulls (files, folders, globs, FreeCAD document variants)"),
}


def parse_faces(text):
    """'1,2,5' -> [1, 2, 5] (FreeCAD's Face1, Face2, ... numbering)."""
    if text is None:
        return None
    try:
        faces = [int(t) for t in text.replace(" ", "").split(",") if t]
    except ValueError:
        raise InputError("--faces takes face numbers separated by commas, e.g. 1,2; got %r" % text) from None
    if not faces or min(faces) < 1:
        raise InputError("--faces numbers start at 1 (Face1); got %r" % text)
    return faces


def add_common_options(p):
    """Options shared by every command that assesses hulls."""
    p.add_argument("--lref", type=float, default=None,
                   help="reference length L_ref in the input's units (default: automatic principal-axis span)")
    p.add_argument("--hf", type=float, default=DEFAULT_HF, help="mean-curvature tolerance h_f (default 1e-4)")
    p.add_argument("--kf", type=float, default=DEFAULT_KF, help="Gaussian-curvature tolerance k_f (default 1e-4)")
    p.add_argument("--backend", choices=("mesh", "brep"), default=None,
                   help="require this realization (default: by input representation)")
    p.add_argument("--faces", default=None, help="BRep faces to assess, e.g. 1,2 (default: all)")
    q = p.add_argument_group("BRep quadrature")
    q.add_argument("--order", type=int, default=None, help="Gauss-Legendre order per direction (default 5)")
    q.add_argument("--rtol", type=float, default=None,
                   help="relative tolerance of the shape's totals (default 1e-4)")
    q.add_argument("--protocol", choices=("budget", "paper"), default=None,
                   help="budget: refinement by the error estimates within a point budget, tolerances on the "
                        "shape's totals (default); paper: each face to --max-depth, rechecked one level deeper")
    q.add_argument("--point-budget", type=int, default=None,
                   help="field points of the whole assessment, shared by the faces by area (default 8000000)")
    q.add_argument("--depth-limit", type=int, default=None,
                   help="levels a cell may be refined below its patch (default 30)")
    q.add_argument("--max-depth", type=int, default=None,
                   help="depth of the paper protocol (default 5; also bounds the halving of few patches)")
    q.add_argument("--jobs", type=int, default=None,
                   help="processes integrating the faces (or the patch groups of a face assessed "
                        "alone) in parallel (default: the available CPUs, or $HULLPROD_JOBS; the "
                        "values do not depend on it)")
    c = p.add_argument_group("BRep faces' store")
    c.add_argument("--cache", default=None, metavar="DIR",
                   help="keep each face's result in DIR and take the unchanged faces from it (default: "
                        "$HULLPROD_FACE_CACHE, else HullProd/faces in FreeCAD's user cache folder; bounded by "
                        "$HULLPROD_FACE_CACHE_SIZE, default 2G, least recently used out first)")
    c.add_argument("--no-cache", action="store_true", help="integrate every face, store none")


#: analyze's options that take a value (the others are flags), for early_reading's scan.
VALUE_OPTIONS = ("--lref", "--hf", "--kf", "--backend", "--faces", "--order", "--rtol", "--max-depth",
                 "--protocol", "--point-budget", "--depth-limit", "--jobs", "--out", "--object", "--cache")


def early_reading(argv):
    """For `analyze FILE` of a BRep file, which api.assess reads in a separate process
    (brep.reading.record_reader.ReadInChild): that process, started at once, so that it reads while
    the argument parser and the backend load here; None for anything else, as far as a
    plain scan of argv tells (short options, abbreviations, a second positional: None).
    run_analyze takes it over when the parsed arguments ask for the same reading, and
    stops it otherwise. For a mesh file, the file's digest (inputs.start_sha256, which the
    mesh path takes up) is begun here instead, for the same reason."""
    if not argv or argv[0] != "analyze":
        return None
    opts, positional = {}, []
    it = iter(argv[1:])
    for a in it:
        if a == "--":
            positional.extend(it)
        elif a.startswith("--"):
            name, eq, value = a.partition("=")
            opts[name] = (value if eq else next(it, None)) if name in VALUE_OPTIONS else True
        elif a.startswith("-") and a != "-":
            return None
        else:
            positional.append(a)
    if len(positional) != 1 or "--help" in opts or opts.get("--backend") == "mesh":
        return None
    path = positional[0]
    ext = os.path.splitext(path)[1].lower()
    if ext in MESH_FORMATS and os.path.isfile(path):
        start_sha256(path)
        return None
    if ext not in BREP_FORMATS or not os.path.isfile(path):
        return None
    try:  # a file whose structure is broken never reaches a reader: describe_file says why
        describe_file(path)
    except InputError:
        return None
    from .brep.reading.record_reader import ReadInChild
    try:
        faces = parse_faces(opts.get("--faces"))
    except (InputError, TypeError, ValueError):
        return None
    cache = False if "--no-cache" in opts else opts.get("--cache")
    return ReadInChild(path, faces, with_fields="--no-fields" not in opts or "--out" in opts, cache=cache)


def quadrature_options(args):
    """The BRep settings the arguments give (api.assess's options), with the faces' store
    (cache: False for --no-cache, the --cache folder, or absent for the default)."""
    cache = False if getattr(args, "no_cache", False) else getattr(args, "cache", None)
    if getattr(args, "no_cache", False) and getattr(args, "cache", None):
        raise InputError("--cache DIR and --no-cache contradict each other: give one")
    return {k: v for k, v in (("order", args.order), ("rtol", args.rtol), ("max_depth", args.max_depth),
                              ("protocol", getattr(args, "protocol", None)),
                              ("point_budget", getattr(args, "point_budget", None)),
                              ("depth_limit", getattr(args, "depth_limit", None)),
                              ("jobs", getattr(args, "jobs", None)), ("cache", cache)) if v is not None}


def build_parser(command=None):
    """The argument parser; plugin commands other than command are listed without options."""
    import argparse
    parser = argparse.ArgumentParser(prog="hullprod", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    a = sub.add_parser("analyze", help="signature of one hull file")
    a.add_argument("input", help="hull file: .stl .obj .ply (mesh), .igs .iges .step .stp .brep (BRep) "
                                 "or a FreeCAD document .FCStd (see --object)")
    add_common_options(a)
    a.add_argument("--object", default=None, metavar="NAME_OR_LABEL",
                   help="object of a .FCStd document to assess (default: its only shape-bearing "
                        "top-level object, or the only visible one of them)")
    a.add_argument("--out", default=None, help="write signature.json/.csv and fields.vtp/.csv here")
    a.add_argument("--overwrite", action="store_true", help="allow writing into a non-empty --out folder")
    a.add_argument("--json", action="store_true", help="print only the JSON document on stdout")
    a.add_argument("--no-fields", action="store_true", help="skip the distributed fields")
    a.add_argument("--report", action="store_true", help="also write report.html into --out")
    a.add_argument("--quiet", action="store_true", help="no progress messages")
    a.set_defaults(func=run_analyze)

    e = sub.add_parser("example", help="generate the built-in example hull and analyse it")
    e.add_argument("--out", default=os.path.join("out", "example"),
                   help="folder for the example geometry and results (default out/example, overwritten)")
    e.add_argument("--json", action="store_true", help="print only the JSON document on stdout")
    e.add_argument("--quiet", action="store_true", help="no progress messages")
    e.set_defaults(func=run_example)

    for cmd, (name, text) in PLUGIN_COMMANDS.items():
        if cmd == command:
            try:
                importlib.import_module(name).add_parser(sub)
                continue
            except ImportError:
                pass
        sub.add_parser(cmd, help=text, add_help=False)
    return parser


def report(result, args, paths=None):
    """Print the signature table (or the JSON document) and where outputs went."""
    if getattr(args, "json", False):
        sys.stdout.write(result.to_json() + "\n")
        for w in result.warnings:
            sys.stderr.write("warning: %s\n" % w)
        return
    print(result.summary_table())
    if paths:
        for kind, path in paths.items():
            print("wrote %-10s %s" % (kind, path))


def run_analyze(args):
    from .api import assess
    progress = null_progress if args.quiet else StderrProgress()
    faces, with_fields = parse_faces(args.faces), not args.no_fields or bool(args.out)
    source, early = args.input, getattr(args, "early_reading", None)
    options = quadrature_options(args)
    if early is not None:
        if (early.path, early.faces, early.with_fields, early.cache) == (args.input, faces, with_fields,
                                                                         options.get("cache")) \
                and args.backend in (None, "brep"):
            source = early  # the reading process started by main (early_reading)
        else:
            early.close()
    result = assess(source, lref=args.lref, h_f=args.hf, k_f=args.kf, backend=args.backend,
                    faces=faces, with_fields=with_fields, progress=progress, object_name=args.object, **options)
    if args.report and not args.out:
        raise InputError("--report writes DIR/report.html: give --out DIR")
    paths = result.save(args.out, overwrite=args.overwrite) if args.out else None
    if args.report:
        from .studies.report import write_report
        paths["report"] = write_report(result, os.path.join(args.out, "report.html"))
    report(result, args, paths)
    return 0


def run_example(args):
    from .api import assess
    from .examples.builtin import write_builtin_example
    progress = null_progress if args.quiet else StderrProgress()
    os.makedirs(args.out, exist_ok=True)
    path, lref, description = write_builtin_example(args.out)
    if not args.json:
        print("built-in example: %s\n  %s" % (description, path))
    t0 = time.perf_counter()
    result = assess(path, lref=lref, progress=progress)
    paths = result.save(os.path.join(args.out, "results"), overwrite=True)
    report(result, args, paths)
    if not args.json:
        print("analysed in %.2f s" % (time.perf_counter() - t0))
    return 0


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    # numerical warnings of the libraries (overflow in a cast of a damaged file's numbers) are
    # not the command's messages: its reasons and validity records say what matters
    import warnings
    warnings.filterwarnings("ignore", category=RuntimeWarning)
    early = early_reading(argv)
    try:
        parser = build_parser(next((a for a in argv if not a.startswith("-")), None))
        args = parser.parse_args(argv)
        args.early_reading = early
        return args.func(args)
    except InputError as exc:
        sys.stderr.write("hullprod: error: %s\n" % " ".join(str(exc).split()))
        return 2
    except KeyboardInterrupt:
        sys.stderr.write("hullprod: interrupted\n")
        return 130
    except Exception as exc:  # an internal fault: one line, the traceback on request
        if os.environ.get("HULLPROD_DEBUG"):
            raise
        sys.stderr.write("hullprod: internal error: %s: %s (set HULLPROD_DEBUG=1 for the traceback)\n"
                         % (type(exc).__name__, " ".join(str(exc).split())))
        return 1
    finally:
        if early is not None:  # taken over and done with, or not wanted
            early.close()


def exit_now(code):
    """End the command with exit status code: run the atexit functions, flush the output and
    leave without the interpreter's teardown (which frees every module and object one by
    one, a cost that grows with numpy, FreeCAD and OpenCascade loaded). The command's files
    are closed when written (result.save, batch.table flushes every row); no thread of its
    own outlives main()."""
    code = 0 if code is None else int(code)
    import atexit
    try:
        atexit._run_exitfuncs()
    finally:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):  # a closed pipe or stream: nothing more to write
                pass
        os._exit(code)


if __name__ == "__main__":
    exit_now(main())
