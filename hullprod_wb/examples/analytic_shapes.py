"""Exact BRep controls built in code (paper section 5.1, Table tab:brepanalytic): Part shapes
with closed-form signatures, for the tests and the installed self-test."""
import math

import numpy as np

from ..freecad_env import import_freecad

FreeCAD = import_freecad()
import Part  # noqa: E402

V = FreeCAD.Vector

#: Closed form for the saddle z = (x^2 - y^2)/4 on [-1, 1]^2 with L_ref = 2 (issue/paper).
SADDLE_I_D = 0.74643563741445
TORUS_R, TORUS_r, TORUS_LREF = 3.0, 1.0, 8.0
TORUS_I_D = 128.0 / (3.0 * math.pi)


def bezier_face(poles):
    """Part.Face of a Bezier surface with poles (nu, nv, 3)."""
    P = np.asarray(poles, float)
    s = Part.BezierSurface()
    s.increase(P.shape[0] - 1, P.shape[1] - 1)
    for i in range(P.shape[0]):
        for j in range(P.shape[1]):
            s.setPole(i + 1, j + 1, V(*P[i, j]))
    return s.toShape()


def patch_grid(bumps=(), n=3):
    """Part faces of n x n bicubic Bezier patches of a smooth hull-like surface over
    [0, 4] x [0, 1] (no closed form: the faces' store and live-update checks change one patch
    and compare); bumps: (patch index, dz) pairs, each moving that patch's pole (2, 2) up."""
    faces = []
    for k in range(n * n):
        i, j = divmod(k, n)
        u = (i + np.linspace(0.0, 1.0, 4))[:, None] / n
        v = (j + np.linspace(0.0, 1.0, 4))[None, :] / n
        P = np.zeros((4, 4, 3))
        P[..., 0], P[..., 1] = 4.0 * u, 1.0 * v + 0 * u
        P[..., 2] = 0.3 * np.sin(2.5 * u) * np.cos(1.7 * v) + 0.1 * (u * v) ** 2
        for index, dz in bumps:
            if index == k:
                P[2, 2, 2] += dz
        faces.append(bezier_face(P))
    return faces


def saddle_face():
    """z = (x^2 - y^2)/4 on [-1, 1]^2 as an exact degree-(2, 2) Bezier patch.

    x = 2u - 1, y = 2v - 1; (2u - 1)^2 has Bernstein coefficients (1, -1, 1).
    """
    a = np.array([1.0, -1.0, 1.0])
    P = np.zeros((3, 3, 3))
    P[:, :, 0] = np.array([-1.0, 0.0, 1.0])[:, None]
    P[:, :, 1] = np.array([-1.0, 0.0, 1.0])[None, :]
    P[:, :, 2] = (a[:, None] - a[None, :]) / 4.0
    return bezier_face(P)


def torus_fractions(R=TORUS_R, r=TORUS_r, lref=TORUS_LREF, k_f=1e-4):
    """Closed-form class fractions (flat, single, elliptic, saddle) of the torus.

    K = cos v / (r (R + r cos v)), dA = r (R + r cos v) du dv; elliptic where
    cos v > tau_K R r/(1 - tau_K r^2)... with r = 1: cos v > tau_K R / (1 - tau_K).
    |H| ~ 1/(2r) >> tau_H in the quasi-zero band, so that band is 'single'.
    """
    tK = k_f / lref ** 2
    cp = tK * R * r / (1.0 - tK * r * r)
    cm = tK * R * r / (1.0 + tK * r * r)

    def area_cos_gt(c):
        a = math.acos(c)
        return 2 * math.pi * r * (2 * R * a + 2 * r * math.sin(a))

    tot = 4 * math.pi ** 2 * R * r
    ell = area_cos_gt(cp) / tot
    sad = (tot - area_cos_gt(-cm)) / tot
    return np.array([0.0, 1.0 - ell - sad, ell, sad])


def torus_shape(R=TORUS_R, r=TORUS_r):
    return Part.makeTorus(R, r)


def unit_sphere():
    return Part.makeSphere(1.0)


def open_cylinder_face(radius=1.0, height=2.0):
    """The lateral face of a cylinder (no caps)."""
    c = Part.makeCylinder(radius, height)
    return [f for f in c.Faces if isinstance(f.Surface, Part.Cylinder)][0]


def plane_face():
    return Part.makePlane(2.0, 3.0)


def sphere_cap(radius=1.0, cap_radius=0.5):
    """Sphere faces trimmed by a circle (the sphere inside a coaxial cylinder): two caps."""
    s = Part.makeSphere(radius)
    c = Part.makeCylinder(cap_radius, 4 * radius, V(0, 0, -2 * radius))
    return s.common(c)


def hemisphere_with_disc():
    """Half ball: a hemisphere face and a flat disc meeting at a C0 crease."""
    return Part.makeSphere(1.0, V(0, 0, 0), V(0, 0, 1), 0, 90)
