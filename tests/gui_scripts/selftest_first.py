"""Run inside `xvfb-run -a freecad` by tests/test_gui_selftest.py: as a person who opens the
Test framework right after starting FreeCAD, before ever choosing the HullProd workbench,
run TestHullProdGui; write what it gave and the active workbench before and after to
$HULLPROD_GUI_RESULT as JSON, then quit. With HULLPROD_WITHOUT_TRIMESH=1, importing trimesh
fails in this session (as where the Addon Manager could not install it)."""
import json
import os
import sys
import traceback

if os.environ.get("HULLPROD_WITHOUT_TRIMESH") == "1":
    sys.modules["trimesh"] = None

import FreeCADGui
from PySide import QtCore

try:
    from PySide import QtWidgets
except ImportError:
    from PySide import QtGui as QtWidgets


def run():
    out = {}
    try:
        out["before"] = FreeCADGui.activeWorkbench().name()
        from hullprod_wb.gui import selftest
        out["suite"] = selftest.run_suite("TestHullProdGui")
        out["after"] = FreeCADGui.activeWorkbench().name()
        try:
            import trimesh  # noqa: F401
            out["trimesh"] = True
        except ImportError:
            out["trimesh"] = False
    except Exception:
        out["exception"] = traceback.format_exc()
    with open(os.environ["HULLPROD_GUI_RESULT"], "w") as fh:
        json.dump(out, fh, indent=1)
    QtWidgets.QApplication.quit()


QtCore.QTimer.singleShot(2000, run)
