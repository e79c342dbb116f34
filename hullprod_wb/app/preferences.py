"""Default analysis settings from FreeCAD's parameter group (no GUI needed).

The Preferences page (hullprod_wb.gui.preferences) edits the same group:
``User parameter:BaseApp/Preferences/Mod/HullProd``.
"""
from ..brep.validity.budget import DEFAULT_QUADRATURE
from ..core.constants import DEFAULT_HF, DEFAULT_KF

PARAM_PATH = "User parameter:BaseApp/Preferences/Mod/HullProd"

#: BRep quadrature defaults (Gauss-Legendre order per direction, local relative tolerance,
#: maximum refinement depth), the values the BRep backend uses when not told otherwise.
DEFAULT_ORDER = 5
DEFAULT_RTOL = 1.0e-4
DEFAULT_MAX_DEPTH = 5

#: name -> (kind, default); kind is the parameter type in FreeCAD's parameter store.
DEFAULTS = {
    "DefaultHf": ("Float", DEFAULT_HF),
    "DefaultKf": ("Float", DEFAULT_KF),
    "QuadratureOrder": ("Int", DEFAULT_ORDER),
    "QuadratureRtol": ("Float", DEFAULT_RTOL),
    "QuadratureMaxDepth": ("Int", DEFAULT_MAX_DEPTH),
    "QuadratureProtocol": ("String", DEFAULT_QUADRATURE.protocol),
    "QuadraturePointBudget": ("Int", DEFAULT_QUADRATURE.point_budget),
    "QuadratureDepthLimit": ("Int", DEFAULT_QUADRATURE.depth_limit),
    "DefaultColorMap": ("String", "Developability"),
    "HideSourceOnAnalyze": ("Bool", True),
}


def _group():
    import FreeCAD
    return FreeCAD.ParamGet(PARAM_PATH)


def get(name):
    """Current value of one setting (the built-in default when never set)."""
    kind, default = DEFAULTS[name]
    return getattr(_group(), "Get" + kind)(name, default)


def set(name, value):  # noqa: A001 - mirrors FreeCAD's Set*/Get* naming
    """Store one setting."""
    kind, _ = DEFAULTS[name]
    getattr(_group(), "Set" + kind)(name, {"Float": float, "Int": int, "Bool": bool, "String": str}[kind](value))


def analysis_defaults():
    """The keyword defaults of make_analysis: h_f, k_f, order, rtol, max_depth, protocol,
    point_budget, depth_limit."""
    return {"h_f": get("DefaultHf"), "k_f": get("DefaultKf"), "order": get("QuadratureOrder"),
            "rtol": get("QuadratureRtol"), "max_depth": get("QuadratureMaxDepth"),
            "protocol": get("QuadratureProtocol"), "point_budget": get("QuadraturePointBudget"),
            "depth_limit": get("QuadratureDepthLimit")}


def reset():
    """Forget every stored setting (back to the built-in defaults)."""
    g = _group()
    for name, (kind, _) in DEFAULTS.items():
        getattr(g, "Rem" + kind)(name)
