"""TestHullProdGui as a person runs it from the Test framework right after starting FreeCAD,
before the HullProd workbench was ever chosen: its four tests pass and the workbench the
person was in is still active afterwards; also where trimesh cannot be imported."""
import json
import os
import shutil
import signal
import subprocess

import pytest

from conftest import ROOT

pytestmark = pytest.mark.skipif(shutil.which("xvfb-run") is None or shutil.which("freecad") is None,
                                reason="xvfb-run or freecad not installed")


@pytest.mark.parametrize("without_trimesh", [False, True], ids=["with_trimesh", "without_trimesh"])
def test_gui_self_test_from_a_fresh_start(tmp_path, without_trimesh):
    home = tmp_path / "home"
    for mod in (home / ".FreeCAD" / "Mod", home / ".local" / "share" / "FreeCAD" / "Mod"):
        mod.mkdir(parents=True)
        (mod / "HullProd").symlink_to(ROOT)
    out = tmp_path / "result.json"
    env = dict(os.environ, HOME=str(home), QTWEBENGINE_CHROMIUM_FLAGS="--no-sandbox", HULLPROD_GUI_RESULT=str(out),
               HULLPROD_WITHOUT_TRIMESH="1" if without_trimesh else "0")
    env.pop("QT_QPA_PLATFORM", None)
    proc = subprocess.Popen(["xvfb-run", "-a", "-s", "-screen 0 1920x1200x24", "freecad",
                             os.path.join(ROOT, "tests", "gui_scripts", "selftest_first.py")],
                            env=env, cwd=str(tmp_path), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            start_new_session=True)
    try:
        stdout, stderr = proc.communicate(timeout=300)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        stdout, stderr = proc.communicate()
        pytest.fail("FreeCAD did not finish in 300 s")
    assert out.is_file(), (stdout[-2000:], stderr[-2000:])
    res = json.loads(out.read_text())
    assert "exception" not in res, res["exception"]
    suite = res["suite"]
    assert suite["run"] >= 4 and suite["failures"] == 0 and suite["errors"] == 0 and suite["skipped"] == 0, suite
    assert res["before"] != "HullProdWorkbench" and res["after"] == res["before"], res
    if without_trimesh:
        assert res["trimesh"] is False
