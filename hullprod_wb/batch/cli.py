"""./hullprod batch INPUTS... : signatures of many hulls, locally in parallel or on Dask."""
import os
import signal
import sys

from ..core.errors import InputError
from ..core.processes import available_cpus

DEFAULT_OUT = os.path.join("out", "batch")


def add_parser(subparsers):
    """Add the `batch` subcommand to the hullprod command line."""
    from ..cli import add_common_options
    b = subparsers.add_parser(
        "batch", help="signatures of many hulls (files, folders, globs, FreeCAD document variants)",
        description="Assess many hulls. Writes OUT/signatures.csv (one row per case, streamed as cases "
                    "finish) and OUT/cases/<case_id>.json; cases already done in OUT with the same input "
                    "and settings are skipped.")
    b.add_argument("inputs", nargs="+", metavar="INPUT",
                   help="hull files (.stl .obj .ply .igs .iges .step .stp .brep), folders, glob patterns "
                        "(quote them), or FreeCAD documents (.FCStd, see --variants)")
    b.add_argument("--out", default=DEFAULT_OUT, help="output folder (default %s)" % DEFAULT_OUT)
    b.add_argument("--workers", type=int, default=None,
                   help="local worker processes (default: CPU count %d; 0: run in this process)"
                        % available_cpus())
    b.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run on a Dask cluster, e.g. tcp://host:8786 (workers need FreeCAD and HullProd)")
    b.add_argument("--variants", default=None, metavar="CSV",
                   help="variant table for the .FCStd inputs: one row per variant, columns are spreadsheet "
                        "aliases (L) or object properties (Body.Length); optional column 'case' names rows")
    b.add_argument("--object", default=None, metavar="NAME",
                   help="hull object of the .FCStd inputs (Name or Label; default: the visible object "
                        "with the largest-area shape)")
    b.add_argument("--no-resume", action="store_true", help="recompute cases already done in --out")
    b.add_argument("--start-method", choices=("spawn", "forkserver", "fork"), default="spawn",
                   help="how local worker processes start (default spawn)")
    b.add_argument("--quiet", action="store_true", help="no progress bar")
    b.add_argument("--case-timeout", type=float, default=None, metavar="S",
                   help="stop a case after S seconds and record it as an error row (default: no "
                        "limit; recorded in the table's case_timeout_s column)")
    b.add_argument("--backend-option", action="append", default=[], metavar="KEY=VALUE",
                   help="further keyword option of the BRep backend, repeatable, e.g. "
                        "display_deflection=0.02 (coarser display samples: faster when fields are not needed)")
    add_common_options(b)
    b.set_defaults(func=run_batch_command)
    return b


def parse_backend_options(items):
    """['key=value', ...] -> {key: value} with numbers and true/false converted."""
    from .api import OPTION_KEYS
    from .cases import _parse_value
    out = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep or not key.strip():
            raise InputError("--backend-option takes KEY=VALUE, got %r" % item)
        if key.strip() in OPTION_KEYS:
            raise InputError("%s is set by its own option (see --help), not by --backend-option" % key.strip())
        low = text.strip().lower()
        out[key.strip()] = {"true": True, "false": False}.get(low, _parse_value(text))
    return out


def _interrupt(signum, frame):
    raise KeyboardInterrupt


def run_batch_command(args):
    from ..cli import parse_faces, quadrature_options
    from .api import run_batch, split_options
    from .cases import expand_cases
    if args.workers is not None and args.workers < 0:
        raise InputError("--workers must be 0 (this process) or more, got %d" % args.workers)
    if args.scheduler is not None and args.workers is not None:
        raise InputError("--workers applies to local runs; with --scheduler the cluster's workers are used")
    settings = split_options(dict(lref=args.lref, h_f=args.hf, k_f=args.kf, backend=args.backend,
                                  faces=parse_faces(args.faces), object=args.object, **quadrature_options(args),
                                  **parse_backend_options(args.backend_option)))
    if args.case_timeout is not None:
        if not args.case_timeout > 0:
            raise InputError("--case-timeout takes a positive number of seconds, got %g" % args.case_timeout)
        settings["case_timeout"] = float(args.case_timeout)  # not part of the settings hash
    cases = expand_cases(args.inputs, variants=args.variants, object_name=args.object)
    signal.signal(signal.SIGTERM, _interrupt)  # a terminated batch stops its workers as Ctrl-C does
    result = run_batch(cases, settings, out=args.out, workers=args.workers, scheduler=args.scheduler,
                       resume=not args.no_resume, progress=not args.quiet, start_method=args.start_method)
    print("%d case(s): %d evaluated, %d skipped (already done), %d failed in %.1f s"
          % (len(cases), result.evaluated, result.skipped, result.failed, result.elapsed_s))
    for case_id, error in result.failures:
        print("  failed %s: %s" % (case_id, error))
    print("wrote table      %s" % result.table_path)
    print("wrote records    %s" % os.path.join(result.out, "cases"))
    sys.stdout.flush()
    return 0
