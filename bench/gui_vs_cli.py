"""GUI Analyze against the command line on the same hulls, side by side in one run.

    /usr/bin/python3 bench/gui_vs_cli.py [--sizes 45,1345] [--runs 2] [--source FILE] [--keep DIR]

A real hull's faces are split into about each of the given numbers of B-spline pieces
(bench/split_hull.py through bench/brep_scale.py's writer: the shared KVLCC2 when present,
else the built-in half-Wigley patch), written as .brep. FreeCAD's GUI then starts under Xvfb
(a private HOME whose Mod folder holds this checkout) and runs the GUI check `gui_vs_cli`
(tests/gui_scripts/gui_checks.py) on those files: for each run, `./hullprod analyze --json`
first, then Analyze in the GUI with default settings (OK pressed until the analysis is made
and coloured), so that both see the same machine. Prints, a file: faces, the GUI's and the
command line's seconds (median and each run), their ratio, and the CPU seconds of the
assessment processes and of FreeCAD's own process. Prints figures only; asserts nothing.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from brep_scale import KVLCC2, log, write_file  # noqa: E402 - after the path

# cold runs: every face integrated, none taken from a store of faces (core.result_store)
os.environ["HULLPROD_FACE_CACHE"] = "off"

SCREEN = "-screen 0 1920x1200x24"


def gui_session(files, work, timeout):
    """Run the GUI check gui_vs_cli on files ([path, runs] pairs); its JSON record."""
    home = os.path.join(work, "home")
    for mod in (os.path.join(home, ".FreeCAD", "Mod"), os.path.join(home, ".local", "share", "FreeCAD", "Mod")):
        os.makedirs(mod, exist_ok=True)
        os.symlink(ROOT, os.path.join(mod, "HullProd"))
    out = os.path.join(work, "result.json")
    env = {k: v for k, v in os.environ.items() if not k.startswith("XDG_") and k not in ("PYTHONPATH", "QT_QPA_PLATFORM")}
    env.update(HOME=home, QTWEBENGINE_CHROMIUM_FLAGS="--no-sandbox", HULLPROD_GUI_RESULT=out,
               HULLPROD_GUI_ONLY="workbench,gui_vs_cli", HULLPROD_GUI_VS_CLI=json.dumps(files),
               HULLPROD_SCREENSHOTS=os.path.join(work, "shots"), HULLPROD_WORK=work)
    script = os.path.join(ROOT, "tests", "gui_scripts", "gui_checks.py")
    subprocess.run(["xvfb-run", "-a", "-s", SCREEN, "freecad", script], env=env, cwd=work, timeout=timeout,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    if not os.path.isfile(out):
        raise RuntimeError("the GUI session wrote no result")
    rec = json.load(open(out))["steps"]["gui_vs_cli"]
    if "exception" in rec:
        raise RuntimeError(rec["exception"])
    return rec


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="45,1345", help="face counts of the split hulls (default 45,1345)")
    ap.add_argument("--runs", type=int, default=2, help="GUI and command-line runs a file (default 2)")
    ap.add_argument("--source", help="hull file to split (default: the shared KVLCC2, else the built-in)")
    ap.add_argument("--timeout", type=float, default=3600.0, help="seconds for the whole GUI session")
    ap.add_argument("--keep", help="keep the split files and the session's folder here")
    a = ap.parse_args()
    source = os.path.abspath(a.source) if a.source else KVLCC2 if os.path.exists(KVLCC2) else ""
    work = a.keep or tempfile.mkdtemp(prefix="hullprod-gui-vs-cli-")
    os.makedirs(work, exist_ok=True)
    try:
        files = []
        for size in sorted(int(s) for s in a.sizes.split(",")):
            w = write_file(source, work, size)
            log("%d faces written (%s)" % (w["faces"], w["how"]))
            files.append([w["path"], a.runs])
        print("source: %s; load average %.2f (%d CPUs)" % (source or "built-in half-Wigley patch",
                                                         os.getloadavg()[0], os.cpu_count()))
        rec = gui_session(files, work, a.timeout)
        print("%6s  %-28s %-28s %6s  %s" % ("faces", "GUI [s] median (runs)", "command [s] median (runs)", "ratio",
                                          "CPU [s]: GUI's assessment processes / FreeCAD / command"))
        for path, _ in files:
            r = rec[path]
            if r.get("errors") or r.get("cli_error") or not r["seconds"]:
                print("%6s  %s" % (r.get("faces", "?"), r.get("errors") or r.get("cli_error")))
                continue
            g, c = float(np.median(r["seconds"])), float(np.median(r["cli_seconds"]))
            cpu = r.get("gui_cpu") or [{}]
            print("%6d  %-28s %-28s %5.2fx  %s / %s" % (
                r["faces"], "%.2f (%s)" % (g, ", ".join("%.2f" % x for x in r["seconds"])),
                "%.2f (%s)" % (c, ", ".join("%.2f" % x for x in r["cli_seconds"])), g / c,
                ", ".join("%.1f/%.1f" % (x["worker"], x["gui"]) for x in cpu),
                ", ".join("%.1f" % i["cpu"] for i in r.get("cli_info") or [])))
        print("load average at the end %.2f" % os.getloadavg()[0])
    finally:
        if not a.keep:
            shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
