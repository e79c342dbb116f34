"""HullProd self-test for FreeCAD's test runner: ``freecadcmd -t TestHullProd``, or the Test
workbench (registered in Init.py). Headless; the checks are hullprod_wb.selftest's."""
import shutil
import tempfile
import unittest

from hullprod_wb import selftest


class _InFolder(unittest.TestCase):
    """A test case with a fresh temporary folder, removed afterwards."""

    def setUp(self):
        self.folder = tempfile.mkdtemp(prefix="hullprod-selftest-")

    def tearDown(self):
        shutil.rmtree(self.folder, ignore_errors=True)


class TestHullProdClosedForms(unittest.TestCase):
    """Native BRep controls against their closed forms (paper Table tab:brepanalytic)."""

    def test_plane(self):
        selftest.check_plane()

    def test_unit_sphere(self):
        selftest.check_unit_sphere()

    def test_torus(self):
        selftest.check_torus()

    def test_saddle(self):
        selftest.check_saddle()

    def test_mesh_sphere(self):
        selftest.check_mesh_sphere()


class TestHullProdFiles(_InFolder):
    """Files as a user brings them: the example hull, a mesh, damaged files."""

    def test_example_hull(self):
        selftest.check_example_hull(self.folder)

    def test_mesh_file(self):
        selftest.check_mesh_file(self.folder)

    def test_damaged_brep_refused(self):
        selftest.check_damaged_brep(self.folder)

    def test_damaged_mesh_refused(self):
        selftest.check_damaged_mesh(self.folder)


class TestHullProdDocument(_InFolder):
    """The analysis object (recompute, save, reopen) and JSON export."""

    def test_analysis_object(self):
        selftest.check_analysis_object(self.folder)

    def test_json_export(self):
        selftest.check_json_export(self.folder)
