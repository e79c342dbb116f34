"""Gaussian curvature zero to rounding on B-spline faces (differential.k_rounding_bound).

On a developable surface K is exactly zero, so every computed K is rounding error: the bound
must hold at every point, and the field then reads K = 0. On a doubly curved surface the bound
stays far below |K| and nothing changes. Towards a collapsed side, where the bound exceeds the
surface's curvature scale, K keeps its computed value. The surfaces sit far from the origin
with a stretched parametrisation, as hull plates from other CAD systems do.
"""
import numpy as np
import pytest

from conftest import needs_freecad
from hullprod_wb.brep.geometry.differential import _components, curvature_fields, k_rounding_bound
from hullprod_wb.brep.geometry.nurbs import NurbsSurfaceData

OFFSET = np.array([2.6e5, 38.0, 1.5e4])  # mm: a plate near a ship's bow, far from the origin


def clamped(n, degree):
    inner = np.linspace(0.0, 1.0, n - degree + 1)[1:-1]
    return np.concatenate([np.zeros(degree + 1), inner, np.ones(degree + 1)])


#: Pole positions along the rulings: unevenly spaced, so S_vv (along the rulings) is not zero
#: and the second form's g = n.S_vv is zero only to rounding.
RULING = np.array([0.0, 0.1, 0.45, 1.0])


def generalised_cylinder(rational=False, seed=0):
    """C(u) + s(v) d: a cubic curve swept along a straight line (K = 0 exactly, weights
    constant along the rulings), 1300 mm along the curve and 80 mm along the rulings, bicubic."""
    rng = np.random.default_rng(seed)
    n = 7
    t = np.linspace(0.0, 1.0, n)
    curve = np.stack([1300.0 * t, 0.0 * t, 400.0 * np.sin(2.0 * t) + rng.uniform(-30, 30, n)], axis=1)
    d = np.array([0.0, 80.0, 5.0])
    poles = curve[:, None, :] + RULING[None, :, None] * d + OFFSET
    weights = np.repeat(rng.uniform(0.6, 1.4, (n, 1)), RULING.size, axis=1) if rational else None
    return NurbsSurfaceData(3, 3, clamped(n, 3), clamped(RULING.size, 3), poles, weights)


def sphere_cap(radius=3000.0):
    """A bicubic B-spline through a sphere's points (K about 1 / radius^2)."""
    n = 8
    a = np.linspace(-0.4, 0.4, n)
    A, B = np.meshgrid(a, a, indexing="ij")
    poles = radius * np.stack([np.sin(A) * np.cos(B), np.sin(B), np.cos(A) * np.cos(B)], axis=2) + OFFSET
    return NurbsSurfaceData(3, 3, clamped(n, 3), clamped(n, 3), poles)


def fields(surface, u, v):
    """(raw K, its rounding bound, K of the field) at (u, v)."""
    der, r = surface.evaluate(u, v, 2), surface.rounding(u, v)
    raw = curvature_fields(der[1:])
    bound = k_rounding_bound(raw.E, raw.G, raw.J, raw.e, raw.f, raw.g, *(_components(x) for x in der[3:]), r)
    zeroed = curvature_fields(der[1:], rounding=(lambda i: r[i], surface.curvature_scale))
    return raw.K, bound, zeroed.K


@pytest.mark.parametrize("rational", [False, True])
def test_developable_surface_K_is_rounding_and_reads_zero(rational):
    s = generalised_cylinder(rational)
    rng = np.random.default_rng(3)
    u, v = rng.uniform(0, 1, 20000), rng.uniform(0, 1, 20000)
    raw, bound, K = fields(s, u, v)
    assert np.any(raw != 0.0)  # the computed K is noise of either sign ...
    assert np.all(np.abs(raw) <= bound)  # ... within the bound everywhere
    assert np.all(bound <= s.curvature_scale)
    assert np.all(K == 0.0)


def test_doubly_curved_surface_is_unchanged():
    s = sphere_cap()
    rng = np.random.default_rng(6)
    u, v = rng.uniform(0, 1, 5000), rng.uniform(0, 1, 5000)
    raw, bound, K = fields(s, u, v)
    assert np.all(bound < 1e-6 * np.abs(raw))
    assert np.array_equal(K, raw)


def test_collapsed_side_keeps_its_computed_K():
    """Poles of the side v = 0 all at one point (a bow's tip): J -> 0 there and the bound grows
    like 1 / J^2, beyond the curvature scale, where K is not zeroed."""
    s = sphere_cap()
    poles = s.poles.copy()
    poles[:, 0] = poles[:, 0].mean(axis=0)
    tip = NurbsSurfaceData(3, 3, s.uknots, s.vknots, poles)
    u = np.linspace(0.05, 0.95, 200)
    for dv in (1e-4, 1e-7, 1e-10):
        raw, bound, K = fields(tip, u, np.full(u.size, dv))
        far = bound > tip.curvature_scale
        assert np.array_equal(K[far], raw[far])
    assert far.any()  # the last distance is inside the rounding's reach


@needs_freecad
def test_developable_face_converges_at_once():
    """The whole command's quadrature on a developable B-spline face far from the origin, at
    the L_ref of a large hull: K noise would otherwise be chased to the point budget."""
    from hullprod_wb.freecad_env import import_freecad
    FreeCAD = import_freecad()
    import Part
    from hullprod_wb import api
    from hullprod_wb.brep.geometry.face_field import FaceField

    s = generalised_cylinder()
    bs = Part.BSplineSurface()
    poles = [[FreeCAD.Vector(*p) for p in row] for row in s.poles]
    bs.buildFromPolesMultsKnots(poles, [4, 1, 1, 1, 4], [4, 4], [0, 0.25, 0.5, 0.75, 1], [0, 1], False, False, 3, 3)
    face = bs.toShape().Faces[0]
    ff = FaceField(face)
    u = np.sort(np.random.default_rng(7).uniform(0, 1, (40, 5)), axis=1)
    v = np.sort(np.random.default_rng(8).uniform(0, 1, (40, 5)), axis=1)
    grid = ff.grid(u, v)["K"]
    points = ff(np.repeat(u[:, :, None], 5, axis=2).ravel(), np.repeat(v[:, None, :], 5, axis=1).ravel())["K"]
    assert np.all(grid == 0.0) and np.all(points == 0.0)
    r = api.assess(face, lref=87000.0, with_fields=False, jobs=1, cache=False)
    assert r.signature["I_D"] == 0.0
    assert r.validity["I_D"].status.value == "VALID"
    assert r.provenance["faces"][0]["points"] < 20000
