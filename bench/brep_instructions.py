"""Work of the native-BRep backend counted in machine instructions, side by side with an
earlier revision: a measure that does not move with the load of a shared machine.

For each hull, the instructions executed (valgrind --tool=callgrind, its "Collected" count)
by one process that imports FreeCAD and this package, reads the file and runs
assess_brep(with_fields=False, cross_checks=False, jobs=1), once with the working tree and once with
REV checked out into a temporary git worktree (both trees byte-compiled first, so that
neither count includes compiling modules); and those of a process that only imports and
reads the file (the fixed part). Prints both counts, their ratio, and the ratio of the
assessments alone (fixed part subtracted). Needs valgrind (Debian: apt-get install valgrind);
runs two processes at a time, about 2 to 5 minutes per hull.

    /usr/bin/python3 bench/brep_instructions.py --base REV [--hulls DIR] [NAME ...]
"""
import argparse
import concurrent.futures
import os
import re
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
HULLS = os.path.normpath(os.path.join(ROOT, "..", "shared", "hulls", "brep"))
DEFAULT = ("wigley_half_wavebem.iges", "series60_half_wavebem.iges", "dtmb5415_half_overture.igs")
#: L_ref per file (L_pp where the source gives it; else automatic).
LREF = {"dtmb5415_half_overture.igs": 5720.0}

# FreeCAD puts its Mod folders (where the installer links this project) on sys.path: the
# tree under test goes in front of them after the import.
SCRIPT = """
import os, sys
sys.path.append('/usr/lib/freecad-python3/lib')
import FreeCAD, Part
sys.path.insert(0, {tree!r})
import hullprod_wb
assert hullprod_wb.__file__.startswith({tree!r}), hullprod_wb.__file__
from hullprod_wb.brep.backend import assess_brep
from hullprod_wb.brep.reading.loading import load_brep
if {assess!r}:
    import inspect  # one process: faces not in workers (revisions that have the option)
    jobs = dict(jobs=1) if "jobs" in inspect.signature(assess_brep).parameters else {{}}
    assess_brep({path!r}, with_fields=False, cross_checks=False, lref={lref!r}, **jobs)
else:
    load_brep({path!r})
"""


def instructions(tree, path, lref, assess=True):
    """Instructions of one process (callgrind's Collected count)."""
    code = SCRIPT.format(tree=tree, path=path, lref=lref, assess=assess)
    # cold: every face integrated, none taken from a store of faces (core.result_store)
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", HULLPROD_FACE_CACHE="off")
    p = subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null",
                        "/usr/bin/python3", "-c", code], capture_output=True, text=True, env=env)
    m = re.search(r"Collected\s*:\s*(\d+)", p.stderr)
    if p.returncode != 0 or not m:
        raise RuntimeError("callgrind run failed in %s: %s" % (tree, p.stderr.strip()[-500:]))
    return int(m.group(1))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", required=True, help="git revision to compare with")
    ap.add_argument("--hulls", default=HULLS)
    ap.add_argument("names", nargs="*", default=DEFAULT)
    args = ap.parse_args()
    if shutil.which("valgrind") is None:
        sys.exit("valgrind not found (Debian: apt-get install valgrind)")
    paths = [os.path.join(args.hulls, n) for n in args.names]
    missing = [p for p in paths if not os.path.exists(p)]
    if missing:
        sys.exit("hull files not found: %s" % ", ".join(missing))
    base = tempfile.mkdtemp(prefix="hullprod-base-")
    subprocess.run(["git", "-C", ROOT, "worktree", "add", "--detach", "-q", base, args.base], check=True)
    try:
        # both trees byte-compiled (as the installer leaves them), so that neither count
        # includes compiling the package's modules; forced: compileall keeps a .pyc whose
        # recorded time equals the source's, which a file edited within the second of its
        # last compile also has, and the import then recompiles it in every process
        for tree in (base, ROOT):
            subprocess.run([sys.executable, "-m", "compileall", "-q", "-f", os.path.join(tree, "hullprod_wb")],
                           check=True)
        print("instructions of one process (callgrind), base %s against the working tree" % args.base)
        print("%-30s %14s %14s %8s %14s %8s" % ("hull", "base", "now", "ratio", "fixed part", "ratio*"))
        with concurrent.futures.ThreadPoolExecutor(2) as pool:
            for name, path in zip(args.names, paths):
                lref = LREF.get(name)
                jobs = [pool.submit(instructions, base, path, lref), pool.submit(instructions, ROOT, path, lref),
                        pool.submit(instructions, ROOT, path, lref, False)]
                b, n, fixed = (j.result() for j in jobs)
                print("%-30s %14d %14d %8.3f %14d %8.3f" % (name, b, n, n / b, fixed,
                                                             (n - fixed) / max(b - fixed, 1)))
                sys.stdout.flush()
        print("ratio*: the assessments alone (the fixed part, imports and reading, subtracted)")
    finally:
        subprocess.run(["git", "-C", ROOT, "worktree", "remove", "--force", base])


if __name__ == "__main__":
    main()
