"""HullProd GUI self-test for FreeCAD's Test workbench (registered in InitGui.py): the
workbench, an analysis's view provider and colours, the Analyze and validity panels seen
on screen. Skipped without the GUI; the checks are hullprod_wb.gui.selftest's."""
import unittest

import FreeCAD


@unittest.skipUnless(FreeCAD.GuiUp, "needs the FreeCAD GUI")
class TestHullProdGui(unittest.TestCase):
    """Each test makes its own document and closes it."""

    def test_workbench_and_commands(self):
        from hullprod_wb.gui import selftest
        selftest.check_workbench()

    def test_analysis_view_provider_and_colours(self):
        from hullprod_wb.gui import selftest
        selftest.check_analysis_view()

    def test_analyze_panel_seen_and_closes(self):
        from hullprod_wb.gui import selftest
        selftest.check_analyze_panel()

    def test_validity_panel_seen_and_closes(self):
        from hullprod_wb.gui import selftest
        selftest.check_validity_panel()
