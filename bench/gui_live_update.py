"""The GUI from an edit of the source to the updated map, with AutoUpdate on.

    /usr/bin/python3 bench/gui_live_update.py [--hull FILE] [--keep DIR]

One face of the hull is changed as bench/face_store.py changes it (an interior pole moved).
FreeCAD's GUI starts under Xvfb (a private HOME whose Mod folder holds this checkout, a fresh
faces' store) and runs the GUI check `live_update_hull` (tests/gui_scripts/gui_checks.py):
the base is analysed, AutoUpdate set, the source's shape replaced by the variant's and the
document recomputed. Prints the seconds of the first analysis, of the recompute after the
edit, from the edit to the updated map, and the longest gap of the event loop meanwhile.
Default hull: the shared closed KCS.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
sys.path.append("/usr/lib/freecad-python3/lib")
from face_store import write_variants  # noqa: E402 - after the path

DEFAULT = os.path.normpath(os.path.join(ROOT, "..", "shared", "hulls", "brep", "kcs_full_closed_ohp.iges"))
SCREEN = "-screen 0 1920x1200x24"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hull", default=DEFAULT, help="BRep file (default: the shared closed KCS)")
    ap.add_argument("--keep", help="keep the files and the session's folder here")
    ap.add_argument("--timeout", type=float, default=1800.0, help="seconds for the GUI session")
    a = ap.parse_args()
    work = a.keep or tempfile.mkdtemp(prefix="hullprod-gui-live-")
    os.makedirs(work, exist_ok=True)
    try:
        number, share = write_variants(a.hull, work, 1)
        home = os.path.join(work, "home")
        for mod in (os.path.join(home, ".FreeCAD", "Mod"), os.path.join(home, ".local", "share", "FreeCAD", "Mod")):
            os.makedirs(mod, exist_ok=True)
            os.symlink(ROOT, os.path.join(mod, "HullProd"))
        out = os.path.join(work, "result.json")
        env = {k: v for k, v in os.environ.items() if not k.startswith("XDG_") and k not in ("PYTHONPATH",
                                                                                          "QT_QPA_PLATFORM")}
        env.update(HOME=home, QTWEBENGINE_CHROMIUM_FLAGS="--no-sandbox", HULLPROD_GUI_RESULT=out,
                   HULLPROD_GUI_ONLY="workbench,live_update_hull", HULLPROD_WORK=work,
                   HULLPROD_SCREENSHOTS=os.path.join(work, "shots"), HULLPROD_FACE_CACHE=os.path.join(work, "store"),
                   HULLPROD_LIVE_UPDATE_FILES=json.dumps([os.path.join(work, "base.brep"),
                                                          os.path.join(work, "variant_1.brep")]))
        subprocess.run(["xvfb-run", "-a", "-s", SCREEN, "freecad", os.path.join(ROOT, "tests", "gui_scripts",
                                                                              "gui_checks.py")],
                       env=env, cwd=work, timeout=a.timeout, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        rec = json.load(open(out))["steps"]["live_update_hull"]
        if "exception" in rec:
            raise SystemExit(rec["exception"])
        print("%s: face %d changed (%.2g of the area); first analysis %.1f s; recompute after the edit %.3f s; "
              "edit to updated map %.2f s (%s hits, %s misses; integrated again: %s); longest event-loop gap %.3f s; "
              "I_D %.6g -> %.6g" % (os.path.basename(a.hull), number, share, rec["first_s"], rec["edit_recompute_s"],
                                    rec["edit_to_map_s"], rec["hits"], rec["misses"], rec["integrated"],
                                    rec["max_gap"], rec["first_I_D"], rec["I_D"]))
    finally:
        if not a.keep:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
