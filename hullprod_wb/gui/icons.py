"""Paths of the workbench's SVG icons (resources/icons)."""
import os

ICON_DIR = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                        "resources", "icons")


def icon(name):
    """Absolute path of resources/icons/<name>.svg."""
    return os.path.join(ICON_DIR, name + ".svg")
