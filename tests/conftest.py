"""Test set-up: the project root and FreeCAD's modules on sys.path, shared paths."""
import os
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from hullprod_wb import freecad_env  # noqa: E402

HAVE_FREECAD = freecad_env.freecad_available()
# Every assessment of the suite integrates its faces (the user's store is neither read nor
# filled); the store's own tests give a folder of their own.
os.environ["HULLPROD_FACE_CACHE"] = "off"
SHARED_HULLS = os.path.normpath(os.path.join(ROOT, "..", "shared", "hulls"))


def shared_hull(relpath):
    """Path of a public hull in ../shared/hulls, or skip the test when it is absent."""
    path = os.path.join(SHARED_HULLS, relpath)
    if not os.path.isfile(path):
        pytest.skip("public hull %s not present (../shared/hulls is outside the repository)" % relpath)
    return path


needs_freecad = pytest.mark.skipif(not HAVE_FREECAD, reason="FreeCAD's Python modules are not importable")


#: Set in a test's own fresh process (clean_process): the node id it runs.
CLEAN_PROCESS_ENV = "HULLPROD_TEST_CLEAN_PROCESS"


def pytest_configure(config):
    config.addinivalue_line("markers", "clean_process: run in a fresh pytest process, with no thread but "
                                       "its own, where worker and reading processes are forked (as in the "
                                       "command); a test process that has meshed no longer forks")


def in_clean_process():
    """Whether this process is a clean_process test's own."""
    return bool(os.environ.get(CLEAN_PROCESS_ENV))


@pytest.hookimpl(tryfirst=True)
def pytest_pyfunc_call(pyfuncitem):
    """A clean_process test runs in a fresh interpreter (its own pytest run of that test)."""
    if pyfuncitem.get_closest_marker("clean_process") is None or in_clean_process():
        return None
    import subprocess
    env = dict(os.environ, **{CLEAN_PROCESS_ENV: pyfuncitem.nodeid, "OPENBLAS_NUM_THREADS": "1",
                              "OMP_NUM_THREADS": "1"})
    p = subprocess.run([sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-q", "-x",
                        "--rootdir", ROOT, pyfuncitem.nodeid], cwd=ROOT, env=env, capture_output=True,
                       text=True, timeout=1200)
    if p.returncode == 0 and " skipped" in p.stdout and " passed" not in p.stdout:
        pytest.skip("in a fresh process: " + p.stdout.strip().splitlines()[-1])
    if p.returncode != 0 or " passed" not in p.stdout:
        pytest.fail("in a fresh process:\n" + p.stdout[-6000:] + p.stderr[-2000:], pytrace=False)
    return True


def made_in_a_child(make):
    """make() (a Part shape) built in a child forked now and rebuilt here from its binary
    BRep data: OpenCascade's modelling (booleans run in parallel on FreeCAD 1.x) starts its
    threads there, and this process may still fork (clean_process tests)."""
    from hullprod_wb.core.processes import ForkedCall
    from hullprod_wb.brep.reading.loading import shape_from_bytes, shape_to_bytes
    return shape_from_bytes(ForkedCall(lambda: shape_to_bytes(make())).result())


def home_with_this_checkout(home):
    """home made a private HOME whose FreeCAD user Mod folders (0.20: ~/.FreeCAD/Mod; later
    versions: ~/.local/share/FreeCAD/Mod) hold this checkout only: FreeCAD started there runs
    the workbench of the tree the test belongs to, whatever is installed for the user."""
    for mod in (home / ".FreeCAD" / "Mod", home / ".local" / "share" / "FreeCAD" / "Mod"):
        mod.mkdir(parents=True)
        (mod / "HullProd").symlink_to(ROOT)
    return home


def fresh_user_env(home):
    """os.environ of a user who has never started FreeCAD: HOME = home, no XDG_ folders, no
    PYTHONPATH."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("XDG_") and k != "PYTHONPATH"}
    env["HOME"] = str(home)
    return env


#: The virtual screen of GUI sessions: larger than the window (1500 x 950, resized up to
#: 1600 x 1000 on the way), since a part of the window off the screen is seen by nobody.
GUI_SCREEN = "-screen 0 1920x1200x24"


def gui_session(script, work, timeout, **env):
    """Run script in the real FreeCAD GUI under Xvfb with a private HOME in work (this
    checkout as its workbench) and env added; the JSON document the script wrote to
    $HULLPROD_GUI_RESULT (work/result.json). The session runs in a process group of its own:
    on a timeout xvfb-run, Xvfb and FreeCAD are all stopped and the test fails."""
    import json
    import signal
    import subprocess
    out = work / "result.json"
    full = dict(os.environ, HOME=str(home_with_this_checkout(work / "home")), QTWEBENGINE_CHROMIUM_FLAGS="--no-sandbox",
                HULLPROD_GUI_RESULT=str(out), **env)
    full.pop("QT_QPA_PLATFORM", None)  # the real window system (Xvfb), not Qt's offscreen plugin
    proc = subprocess.Popen(["xvfb-run", "-a", "-s", GUI_SCREEN, "freecad", script], env=full, cwd=str(work),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, encoding="utf-8",
                            errors="replace", start_new_session=True)
    try:
        stdout, stderr = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        stdout, stderr = proc.communicate()
        pytest.fail("FreeCAD GUI session did not finish in %d s (a modal dialog?): %s" % (timeout, stdout[-2000:]))
    assert out.is_file(), "GUI script wrote no result; FreeCAD said:\n%s\n%s" % (stdout[-3000:], stderr[-3000:])
    return json.loads(out.read_text())
