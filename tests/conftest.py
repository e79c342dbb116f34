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
