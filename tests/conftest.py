"""Test set-up: the project root and FreeCAD's modules on sys.path, shared paths."""
import os
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from hullprod_wb import freecad_env  # noqa: E402

HAVE_FREECAD = freecad_env.freecad_available()
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
