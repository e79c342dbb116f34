"""Workbench set-up, called from InitGui.py's HullProdWorkbench.Initialize."""
from . import commands
from .icons import ICON_DIR


def initialize(wb):
    """Register the commands, the 'HullProd' toolbar and menu (with its Verification
    submenu), icons and the preferences page."""
    import FreeCADGui
    commands.register()
    FreeCADGui.addIconPath(ICON_DIR)
    wb.appendToolbar("HullProd", list(commands.TOOLBAR))
    wb.appendMenu("&HullProd", list(commands.TOOLBAR))
    from . import verification_commands
    wb.appendMenu(["&HullProd", "&Verification"], verification_commands.register())
    from .preferences import PreferencesPage
    FreeCADGui.addPreferencePage(PreferencesPage, "HullProd")
    return wb
