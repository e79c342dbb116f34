"""Benchmark of the native-BRep backend on the shared public hulls.

For each hull in ../shared/hulls/brep: wall time and CPU time (the command with the worker
processes it integrates faces in) of the whole command (`./hullprod analyze FILE --json`),
the worker processes used, quadrature points evaluated and the seven statuses.
With --reference, the same files go through the paper's reference package (hullprod 1.0.1
from PyPI, installed into a throwaway virtual environment, never a project dependency) in
the same run, and the time ratios are printed: of the whole commands, of the commands less
each tool's start-up (the best of three `--help` runs: interpreter and imports), and of their
CPU times. Each command runs --repeat times (default 3; the reference only while one of its
runs takes under REPEAT_LIMIT seconds, else once), the two tools in turn (ours, the
reference, ours, ...) so that both meet the same state of the machine, and the medians are
compared: on a shared machine single runs of a fraction of a second move by 10 % and more,
and the machine's speed drifts by tens of percent within minutes. The package is
byte-compiled first, so that no run compiles modules (where Python does not write its
caches, every run would compile the modules changed since the last compilation).

    /usr/bin/python3 bench/brep_hulls.py [--reference] [--repeat N] [--venv DIR] [--hulls DIR]
"""
import argparse
import glob
import json
import os
import resource
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from reference_venv import ensure_reference_venv  # noqa: E402

# cold runs: every face integrated, none taken from a store of faces (core.result_store)
os.environ["HULLPROD_FACE_CACHE"] = "off"

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
HULLS = os.path.normpath(os.path.join(ROOT, "..", "shared", "hulls", "brep"))
#: L_ref per file (L_pp where the source gives it; else None: automatic).
LREF = {"dtmb5415_half_overture.igs": 5720.0}
METRICS = ("I_D", "I_D_plus", "I_D_minus", "a_flat", "a_single", "a_elliptic", "a_saddle")
#: The reference is run --repeat times only while a run of it takes under this (seconds).
REPEAT_LIMIT = 60.0


def timed_run(cmd, **kw):
    """subprocess.run(cmd) with its wall time and its CPU time (user + system of the command and
    of the worker processes it waited for)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True, **kw)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return p, wall, cpu


def startup(cmd, repeat=3):
    """Best wall time of `cmd --help` (start-up: interpreter, imports, argument parsing)."""
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        subprocess.run(cmd + ["--help"], capture_output=True)
        best = min(best, time.perf_counter() - t)
    return best


def run_ours(path, lref):
    cmd = [os.path.join(ROOT, "hullprod"), "analyze", path, "--json", "--quiet", "--no-fields"]
    if lref:
        cmd += ["--lref", str(lref)]
    p, wall, cpu = timed_run(cmd)
    if p.returncode != 0:
        return {"wall": wall, "cpu": cpu, "error": p.stderr.strip()[-300:]}
    doc = json.loads(p.stdout)
    return {"wall": wall, "cpu": cpu, "jobs": max(doc["options"].get("jobs") or 1, doc["options"].get("group_jobs") or 1), "I_D": doc["signature"]["I_D"],
            "statuses": [doc["validity"][m]["status"] for m in METRICS],
            "points": doc["options"].get("points_evaluated")}


def median_run(results):
    """The result of the run with the median wall time, with the wall times of all runs
    ("walls")."""
    res = dict(sorted(results, key=lambda r: r["wall"])[(len(results) - 1) // 2])
    res["walls"] = [r["wall"] for r in results]
    return res


def alternating(run_a, run_b, repeat, limit_b=None):
    """run_a() and run_b() (None: none) in turn, repeat times each, so that both see the same
    state of a shared machine (run_b fewer times once one of its runs took limit_b seconds
    or more; run_a then goes on alone); the median runs of both (median_run)."""
    a, b = [], []
    for _ in range(max(1, repeat)):
        a.append(run_a())
        if run_b is not None and not (b and ("error" in b[-1] or (limit_b is not None and b[-1]["wall"] >= limit_b))):
            b.append(run_b())
        if "error" in a[-1]:
            break
    return median_run(a), (median_run(b) if b else None)


def _find(obj, key):
    """First value of key anywhere in a nested JSON object."""
    if isinstance(obj, dict):
        if key in obj:
            return obj[key]
        for v in obj.values():
            r = _find(v, key)
            if r is not None:
                return r
    elif isinstance(obj, list):
        for v in obj:
            r = _find(v, key)
            if r is not None:
                return r
    return None


def run_reference(exe, path, lref):
    out = tempfile.mkdtemp(prefix="hullprod-ref-")
    cmd = [exe, path, "--out", out, "--overwrite", "--no-plots", "--quiet"]
    if lref:
        cmd += ["--lref", str(lref)]
    # a fresh result cache each run, so that nothing is reused between runs
    env = dict(os.environ, HULLPROD_CACHE_DIR=tempfile.mkdtemp(prefix="hullprod-ref-cache-"))
    p, wall, cpu = timed_run(cmd, env=env)
    res = {"wall": wall, "cpu": cpu}
    sig = os.path.join(out, "signature.json")
    if p.returncode != 0 or not os.path.exists(sig):
        res["error"] = (p.stderr or p.stdout).strip()[-300:]
        return res
    doc = json.load(open(sig))
    res["I_D"] = _find(doc, "I_D")
    val = os.path.join(out, "validity.json")
    text = open(val).read() if os.path.exists(val) else json.dumps(doc)
    res["unconverged"] = text.count("UNCONVERGED")
    return res


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reference", action="store_true", help="also run hullprod 1.0.1 and print ratios")
    ap.add_argument("--venv", default=os.path.join(tempfile.gettempdir(), "hullprod-ref-venv"))
    ap.add_argument("--hulls", default=HULLS)
    ap.add_argument("--repeat", type=int, default=3, help="runs of each command; medians compared (default 3)")
    args = ap.parse_args()
    files = sorted(glob.glob(os.path.join(args.hulls, "*.ig*s")) + glob.glob(os.path.join(args.hulls, "*.st*p")))
    if not files:
        sys.exit("no BRep hulls found in %s" % args.hulls)
    exe = ensure_reference_venv(args.venv) if args.reference else None
    # byte-compiled first: where Python does not write its caches (PYTHONDONTWRITEBYTECODE,
    # a read-only checkout) every run would otherwise compile the modules changed since the
    # last compilation; forced, since compileall keeps a .pyc whose recorded time equals its
    # source's, which a file edited within the second of its last compile also has
    subprocess.run([sys.executable, "-m", "compileall", "-q", "-f", os.path.join(ROOT, "hullprod_wb")], check=True)
    s_ours = startup([os.path.join(ROOT, "hullprod")])
    s_ref = startup([exe]) if exe else None
    print("start-up (best of 3 --help): HullProd for FreeCAD %.2f s%s" % (
        s_ours, "" if s_ref is None else ", reference %.2f s" % s_ref))
    print("%-30s %9s %8s %5s %11s %12s  %-58s" % ("hull", "ours [s]", "CPU [s]", "jobs", "points", "I_D",
                                                 "statuses (I_D I_D+ I_D- flat single ell saddle)"))
    rows = []
    for f in files:
        name = os.path.basename(f)
        ours, ref = alternating(lambda: run_ours(f, LREF.get(name)),
                                (lambda: run_reference(exe, f, LREF.get(name))) if exe else None,
                                args.repeat, REPEAT_LIMIT)
        rows.append((name, ours, ref))
        print("%-30s %9.2f %8.2f %5s %11s %12s  %s" % (name, ours["wall"], ours["cpu"], ours.get("jobs"), ours.get("points"),
                                            "%.6g" % ours["I_D"] if ours.get("I_D") is not None else "null",
                                            " ".join(ours.get("statuses", [ours.get("error", "")]))))
        print("%-30s %s" % ("", "our runs: " + " ".join("%.2f" % w for w in ours["walls"]) + " s"))
        if ref:
            work = (ref["wall"] - s_ref) / max(ours["wall"] - s_ours, 1e-9)
            print("%-30s %9.2f %8.2f %5s %11s %12s  reference hullprod 1.0.1: %s UNCONVERGED mentions; %.1fx slower "
                  "(%.1fx without start-up; CPU time %.1fx)"
                  % ("", ref["wall"], ref["cpu"], "", "", "%.6g" % ref["I_D"] if isinstance(ref.get("I_D"), (int, float)) else "null",
                     ref.get("unconverged", ref.get("error")), ref["wall"] / ours["wall"], work,
                     ref["cpu"] / max(ours["cpu"], 1e-9)))
            print("%-30s %s" % ("", "reference runs: " + " ".join("%.2f" % w for w in ref["walls"]) + " s"))
        sys.stdout.flush()


if __name__ == "__main__":
    main()
