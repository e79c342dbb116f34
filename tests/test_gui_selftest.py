"""TestHullProdGui as a person runs it from the Test framework right after starting FreeCAD,
before the HullProd workbench was ever chosen: its four tests pass and the workbench the
person was in is still active afterwards; also where trimesh cannot be imported."""
import os
import shutil

import pytest

from conftest import ROOT, gui_session

pytestmark = pytest.mark.skipif(shutil.which("xvfb-run") is None or shutil.which("freecad") is None,
                                reason="xvfb-run or freecad not installed")


@pytest.mark.parametrize("without_trimesh", [False, True], ids=["with_trimesh", "without_trimesh"])
def test_gui_self_test_from_a_fresh_start(tmp_path, without_trimesh):
    res = gui_session(os.path.join(ROOT, "tests", "gui_scripts", "selftest_first.py"), tmp_path, 300,
                      HULLPROD_WITHOUT_TRIMESH="1" if without_trimesh else "0")
    assert "exception" not in res, res["exception"]
    suite = res["suite"]
    assert suite["run"] >= 4 and suite["failures"] == 0 and suite["errors"] == 0 and suite["skipped"] == 0, suite
    assert res["before"] != "HullProdWorkbench" and res["after"] == res["before"], res
    if without_trimesh:
        assert res["trimesh"] is False
