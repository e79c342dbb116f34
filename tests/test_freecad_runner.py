"""The workbench as FreeCAD sees it: tools/install.sh links it where FreeCAD looks for a fresh
user, Init.py registers the self-test, and FreeCAD's own runner (`freecadcmd -t TestHullProd`)
runs it from there, exiting non-zero when a check fails."""
import os
import re
import shutil
import subprocess

import pytest

from conftest import ROOT, fresh_user_env

pytestmark = pytest.mark.skipif(shutil.which("freecadcmd") is None, reason="freecadcmd is not installed")


def freecadcmd(env, *args, cwd):
    return subprocess.run(["freecadcmd"] + list(args), capture_output=True, text=True, env=env, cwd=str(cwd),
                          timeout=600)


def user_mod_folder(env, cwd):
    """FreeCAD's user Mod folder for env, as FreeCAD reports it."""
    r = freecadcmd(env, "-c", "import FreeCAD; print('USERDIR=' + FreeCAD.getUserAppDataDir())", cwd=cwd)
    found = re.findall(r"^USERDIR=(.*)$", r.stdout, re.M)
    assert found, r.stdout + r.stderr
    return os.path.join(found[-1], "Mod")


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """A fresh user's HOME after tools/install.sh: (env, work folder)."""
    home = tmp_path_factory.mktemp("fresh_user")
    work = tmp_path_factory.mktemp("elsewhere")
    env = fresh_user_env(home)
    r = subprocess.run(["bash", os.path.join(ROOT, "tools", "install.sh")], capture_output=True, text=True, env=env,
                       timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    return env, work


def test_install_links_where_freecad_looks(installed):
    env, work = installed
    mod = user_mod_folder(env, work)
    link = os.path.join(mod, "HullProd")
    assert os.path.realpath(link) == os.path.realpath(ROOT), "%s is not a link to this checkout" % link
    if "/v1-" in mod:  # FreeCAD 1.1 and later: no unversioned folder made behind its back
        assert not os.path.exists(os.path.join(env["HOME"], ".local", "share", "FreeCAD", "Mod"))
    r = freecadcmd(env, "-c", "import FreeCAD, hullprod_wb; print('PKG=' + hullprod_wb.__file__); "
                   "print('UNIT=' + ' '.join(FreeCAD.__unit_test__))", cwd=work)
    pkg = re.findall(r"^PKG=(.*)$", r.stdout, re.M)
    assert pkg and os.path.realpath(pkg[-1]).startswith(os.path.realpath(ROOT)), r.stdout + r.stderr
    assert "TestHullProd" in re.findall(r"^UNIT=(.*)$", r.stdout, re.M)[-1].split()


def test_freecad_runs_the_self_test(installed):
    """freecadcmd -t TestHullProd: exit 0, at least 10 tests, OK, in under a minute."""
    env, work = installed
    r = freecadcmd(env, "-t", "TestHullProd", cwd=work)
    out = r.stdout + r.stderr
    ran = re.findall(r"^Ran (\d+) tests? in ([\d.]+)s", out, re.M)
    assert r.returncode == 0 and ran and re.search(r"^OK", out, re.M), out[-4000:]
    count, seconds = int(ran[-1][0]), float(ran[-1][1])
    assert count >= 10 and seconds < 60, (count, seconds)


def test_a_failing_check_fails_the_run(installed):
    """A self-test whose sphere is not the unit sphere fails, and the runner exits non-zero. The
    altered module is a Mod folder of its own (FreeCAD 1.1 does not read PYTHONPATH)."""
    env, work = installed
    mod = os.path.join(user_mod_folder(env, work), "HullProdAltered")
    os.makedirs(mod, exist_ok=True)
    with open(os.path.join(mod, "TestHullProdAltered.py"), "w") as fh:
        fh.write("import Part\n"
                 "from hullprod_wb.examples import analytic_shapes\n"
                 "analytic_shapes.unit_sphere = lambda: Part.makeSphere(1.1)\n"
                 "from TestHullProd import TestHullProdClosedForms  # noqa: F401\n")
    r = freecadcmd(env, "-t", "TestHullProdAltered.TestHullProdClosedForms.test_unit_sphere", cwd=work)
    out = r.stdout + r.stderr
    assert r.returncode != 0 and "sphere I_D is" in out and "FAILED (failures=1)" in out, out[-3000:]
