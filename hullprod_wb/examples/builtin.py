"""The built-in example hull: the half-Wigley hull as an exact Bezier patch, saved as STEP.

y = B/2 [1 - (2x/L)^2] [1 - (z/T)^2],  -L/2 <= x <= L/2,  -T <= z <= 0   (paper section 5.1)

With x = L (u - 1/2) and z = T (v - 1), y = B/2 f(u) g(v), f = 4u(1-u) and g = v(2-v), both
quadratic, so the surface is exactly a degree-(2, 2) Bezier patch with poles
x_i = L (i/2 - 1/2), z_j = T (j/2 - 1), y_ij = B/2 f_i g_j, f = (0, 2, 0), g = (0, 1, 1).
"""
import os

import numpy as np

#: Principal particulars of the example (consistent length units; L_ref = L).
WIGLEY_L, WIGLEY_B, WIGLEY_T = 1.0, 0.1, 0.0625

#: Semi-analytical reference values for this hull (paper Table tab:brepanalytic).
WIGLEY_REFERENCE = {"I_D": 4.30990339, "I_D_plus": 2.15495169, "I_D_minus": 2.15495169}


def half_wigley_poles(L=WIGLEY_L, B=WIGLEY_B, T=WIGLEY_T):
    """(3, 3, 3) float Bezier poles of the half-Wigley patch (see module docstring)."""
    f = np.array([0.0, 2.0, 0.0])
    g = np.array([0.0, 1.0, 1.0])
    P = np.zeros((3, 3, 3))
    P[:, :, 0] = (L * (np.arange(3) / 2.0 - 0.5))[:, None]
    P[:, :, 1] = 0.5 * B * f[:, None] * g[None, :]
    P[:, :, 2] = (T * (np.arange(3) / 2.0 - 1.0))[None, :]
    return P


def half_wigley_shape(L=WIGLEY_L, B=WIGLEY_B, T=WIGLEY_T):
    """Part.Face of the exact half-Wigley Bezier patch."""
    from ..freecad_env import import_freecad
    FreeCAD = import_freecad()
    import Part
    P = half_wigley_poles(L, B, T)
    surf = Part.BezierSurface()
    surf.increase(2, 2)
    for i in range(3):
        for j in range(3):
            surf.setPole(i + 1, j + 1, FreeCAD.Vector(*P[i, j]))
    return surf.toShape()


def write_builtin_example(folder):
    """Write the example STEP into folder; return (path, L_ref, description)."""
    path = os.path.join(folder, "half_wigley.step")
    half_wigley_shape().exportStep(path)
    desc = ("half-Wigley hull L=%g B=%g T=%g as an exact degree-(2,2) Bezier patch (STEP), L_ref = L; "
            "reference I_D = %.8f" % (WIGLEY_L, WIGLEY_B, WIGLEY_T, WIGLEY_REFERENCE["I_D"]))
    return path, WIGLEY_L, desc
