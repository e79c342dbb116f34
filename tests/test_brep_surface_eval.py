"""Batched BRep surface evaluation and differential geometry against OpenCascade.

Tolerances: our code and OpenCascade evaluate the same exact formulas in double precision,
so they differ only by rounding. Errors are measured against face-level scales (points
against max|S|, first derivatives against s1 = max|S_u|,|S_v|, second derivatives against
s2 = max(max|S_uu|,|S_uv|,|S_vv|, s1 / parameter extent), H against the curvature scale
kref = max(max|k|, s2 / s1^2), K against kref^2), because quantities that vanish exactly
(e.g. S_uv of a ruled patch) carry pure rounding noise. Observed errors are <= 1e-10 (most
<= 1e-13) even on hull faces whose coordinates are ~1e3 times their local scale; 1e-9 leaves
room for that conditioning while any formula or parameterisation error is O(1).
"""
import math
import time

import numpy as np
import pytest

from conftest import needs_freecad, shared_hull
from hullprod_wb.brep.geometry import differential
from hullprod_wb.brep.geometry.nurbs import NurbsSurfaceData
from hullprod_wb.brep.geometry.surface_eval import SurfaceEvaluator, face_surface
from hullprod_wb.core.errors import InputError

TOL = 1e-9  # see module docstring


@pytest.fixture(scope="module")
def fc():
    from hullprod_wb.freecad_env import import_freecad

    FreeCAD = import_freecad()
    import Part

    return FreeCAD, Part


# ---------------------------------------------------------------------------- helpers
def occ_derivatives(surface, u, v):
    """(6, n, 3): S, Su, Sv, Suu, Suv, Svv from OpenCascade, point by point."""
    out = np.empty((6, len(u), 3))
    orders = ((1, 0), (0, 1), (2, 0), (1, 1), (0, 2))
    for i, (a, b) in enumerate(zip(u, v)):
        p = surface.value(float(a), float(b))
        out[0, i] = (p.x, p.y, p.z)
        for k, (nu, nv) in enumerate(orders, 1):
            d = surface.getDN(float(a), float(b), nu, nv)
            out[k, i] = (d.x, d.y, d.z)
    return out


def occ_curvatures(surface, u, v):
    """OpenCascade's mean and Gaussian curvature (NaN where it reports none)."""
    def one(a, b, kind):
        try:
            return surface.curvature(float(a), float(b), kind)
        except Exception:  # 'No curvature defined' at degenerate points
            return np.nan

    return (np.array([one(a, b, "Mean") for a, b in zip(u, v)]),
            np.array([one(a, b, "Gauss") for a, b in zip(u, v)]))


def scales(ref, prange):
    u0, u1, v0, v1 = prange
    nrm = np.linalg.norm(ref, axis=2)
    s0 = nrm[0].max()
    s1 = nrm[1:3].max()
    s2 = max(nrm[3:].max(), s1 / max(u1 - u0, v1 - v0))
    return s0, s1, s2


def compare_with_occ(ev, surface, u, v, check_curvature=True):
    """Max scaled errors (S, first, second derivatives, H, K) of ev against OCC."""
    mine = np.array(ev.derivatives(u, v))
    ref = occ_derivatives(surface, u, v)
    s0, s1, s2 = scales(ref, ev.parameter_range)
    dif = np.linalg.norm(mine - ref, axis=2)
    errs = [dif[0].max() / s0, dif[1:3].max() / s1, dif[3:].max() / s2]
    if check_curvature:
        d = ev.differentials(u, v)
        h_occ, k_occ = occ_curvatures(surface, u, v)
        # OCC's mean curvature uses the normal S_u x S_v of the surface (eq:brep_normal with
        # s = +1): H_ours = orientation_sign * H_occ; K needs no sign.
        h_occ = ev.orientation_sign * h_occ
        ok = d.regular & np.isfinite(h_occ)
        assert ok.any()
        kref = max(np.max(np.maximum(np.abs(d.k1), np.abs(d.k2))[ok]), s2 / s1 ** 2)
        errs += [np.max(np.abs(d.H - h_occ)[ok]) / kref, np.max(np.abs(d.K - k_occ)[ok]) / kref ** 2]
    return np.array(errs)


def assert_matches_face_value(ev, face, u, v):
    """Points agree with the face's own evaluation (placement/location included)."""
    ref = np.array([tuple(face.valueAt(float(a), float(b))) for a, b in zip(u, v)])
    scale = max(np.abs(ref).max(), 1.0)
    assert np.max(np.abs(ev.points(u, v) - ref)) <= 1e-12 * scale  # coordinates: rounding only


def random_uv(rng, prange, n):
    u0, u1, v0, v1 = prange
    u, v = rng.uniform(u0, u1, n), rng.uniform(v0, v1, n)
    u[:4], v[:4] = [u0, u1, u0, u1], [v0, v0, v1, v1]  # the corners, ends of the domain included
    return u, v


def make_bspline(fc, rational=False, seed=0):
    """Degree 3 x 2, non-uniform knots, interior knot multiplicities 1 and 2 (both directions)."""
    FreeCAD, Part = fc
    rng = np.random.default_rng(seed)
    nu, nv = 7, 6
    poles = [[FreeCAD.Vector(10 * i + rng.random(), 7 * j + rng.random(), 3 * math.sin(i + 0.7 * j) + rng.random())
              for j in range(nv)] for i in range(nu)]
    s = Part.BSplineSurface()
    args = (poles, [4, 1, 2, 4], [3, 1, 2, 3], [0.0, 0.7, 1.5, 3.0], [-1.0, 0.2, 0.5, 2.0], False, False, 3, 2)
    if rational:
        s.buildFromPolesMultsKnots(*args, [[0.5 + rng.random() for _ in range(nv)] for _ in range(nu)])
    else:
        s.buildFromPolesMultsKnots(*args)
    return s


def make_periodic_bspline(fc, seed=1):
    """Cubic, periodic in u (closed tube with non-uniform knots), clamped in v."""
    FreeCAD, Part = fc
    rng = np.random.default_rng(seed)
    poles = [[FreeCAD.Vector((2 + 0.3 * j) * math.cos(2 * math.pi * i / 6) + 0.1 * rng.random(),
                             (2 + 0.1 * j) * math.sin(2 * math.pi * i / 6), j + 0.1 * rng.random())
              for j in range(4)] for i in range(6)]
    s = Part.BSplineSurface()
    s.buildFromPolesMultsKnots(poles, [1] * 7, [4, 4], [0, 1, 2, 3.5, 4, 5, 6], [0, 1], True, False, 3, 3,
                               [[0.7 + 0.5 * rng.random() for _ in range(4)] for _ in range(6)])
    return s


def make_periodic_circle_cylinder(fc, radius=2.0, height=3.0):
    """Exact rational periodic B-spline cylinder: degree-2 periodic circle (8 poles) x line."""
    FreeCAD, Part = fc
    w = math.sqrt(0.5)
    ring = [(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1)]
    poles = [[FreeCAD.Vector(radius * x, radius * y, z) for z in (0.0, height)] for x, y in ring]
    weights = [[1.0 if k % 2 == 0 else w] * 2 for k in range(8)]
    s = Part.BSplineSurface()
    q = math.pi / 2
    s.buildFromPolesMultsKnots(poles, [2] * 5, [2, 2], [0, q, 2 * q, 3 * q, 4 * q], [0, 1], True, False, 2, 1,
                               weights)
    return s


def placement(fc):
    FreeCAD, _ = fc
    return FreeCAD.Placement(FreeCAD.Vector(1.5, -2.0, 3.25), FreeCAD.Rotation(FreeCAD.Vector(1, 2, 0.5), 37))


def analytic_faces(fc):
    """(name, face) with non-trivial placements; faces of Part's primitive makers."""
    FreeCAD, Part = fc
    pl = placement(fc)
    faces = {
        "plane": Part.Plane(FreeCAD.Vector(1, 2, 3), FreeCAD.Vector(0.2, 0.3, 1)).toShape(-2, 3, -1, 4),
        "cylinder": Part.makeCylinder(2.5, 4.0).Faces[0],
        "cone_opening": Part.makeCone(1.0, 3.0, 4.0).Faces[0],
        "cone_closing": Part.makeCone(3.0, 1.0, 4.0).Faces[0],  # negative semi-angle
        "cone_apex": Part.makeCone(0.0, 3.0, 4.0).Faces[0],  # reference radius 0
        "sphere": Part.makeSphere(2.0).Faces[0],
        "torus": Part.makeTorus(3.0, 1.0).Faces[0],
    }
    out = []
    for name, face in faces.items():
        face = face.copy()
        face.Placement = pl
        out.append((name, face))
    return out


def mirrored(fc, surface):
    """Copy reflected in a plane: a left-handed local frame (indirect gp_Ax3)."""
    FreeCAD, _ = fc
    s = surface.copy()
    m = FreeCAD.Matrix()
    m.scale(1, -1, 1)
    s.transform(m)
    return s


# ---------------------------------------------------------------------------- NURBS vs OCC
@needs_freecad
@pytest.mark.parametrize("rational", [False, True])
def test_bspline_derivatives_and_curvature_match_occ(fc, rational):
    s = make_bspline(fc, rational)
    ev = SurfaceEvaluator.for_surface(s)
    assert ev.kind == "bspline" and ev.nurbs.rational == rational
    u, v = random_uv(np.random.default_rng(3), ev.parameter_range, 300)
    errs = compare_with_occ(ev, s, u, v)
    assert np.all(errs <= TOL), errs


@needs_freecad
def test_bspline_at_knots_and_domain_end_matches_occ(fc):
    """Interior knots are right-continuous (C0/C1 knots included), the domain end uses the last span."""
    s = make_bspline(fc, rational=True)
    ev = SurfaceEvaluator.for_surface(s)
    uk, vk = [0.0, 0.7, 1.5, 3.0], [-1.0, 0.2, 0.5, 2.0]
    uu, vv = np.meshgrid(uk, vk, indexing="ij")
    u, v = uu.ravel(), vv.ravel()
    mine = np.array(ev.derivatives(u, v))
    assert np.all(np.isfinite(mine))
    errs = compare_with_occ(ev, s, u, v, check_curvature=False)
    assert np.all(errs <= TOL), errs
    # the last corner, exactly at the end of the domain
    end = np.array(ev.derivatives(3.0, 2.0))[:, 0]
    ref = occ_derivatives(s, [3.0], [2.0])[:, 0]
    assert np.allclose(end, ref, rtol=0, atol=TOL * np.abs(ref).max())


@needs_freecad
def test_bezier_matches_occ(fc):
    FreeCAD, Part = fc
    rng = np.random.default_rng(4)
    b = Part.BezierSurface()
    b.increase(2, 2)
    for i in range(3):
        for j in range(3):
            b.setPole(i + 1, j + 1, FreeCAD.Vector(i + 0.2 * rng.random(), j + 0.2 * rng.random(), rng.random()))
            b.setWeight(i + 1, j + 1, 0.5 + rng.random())
    ev = SurfaceEvaluator.for_surface(b)
    assert ev.kind == "bezier" and ev.nurbs.udegree == 2 and ev.nurbs.vdegree == 2 and ev.nurbs.rational
    u, v = random_uv(rng, ev.parameter_range, 200)
    errs = compare_with_occ(ev, b, u, v)
    assert np.all(errs <= TOL), errs


@needs_freecad
def test_periodic_bspline_matches_occ_outside_base_period(fc):
    s = make_periodic_bspline(fc)
    assert s.isUPeriodic()
    ev = SurfaceEvaluator.for_surface(s, parameter_range=(-7.0, 13.0, 0.0, 1.0))  # ~3 periods
    assert s.isUPeriodic(), "the caller's surface must not be made non-periodic"
    u, v = random_uv(np.random.default_rng(5), ev.parameter_range, 300)
    u[4:9] = [0.0, 6.0, 12.0, -6.0, 3.5]  # seam, its periodic images and a knot
    errs = compare_with_occ(ev, s, u, v)
    assert np.all(errs <= TOL), errs


@needs_freecad
def test_periodic_rational_circle_cylinder(fc):
    """Exact rational periodic cylinder: OCC agreement, K = 0, |H| = 1/(2R)."""
    s = make_periodic_circle_cylinder(fc, radius=2.0)
    ev = SurfaceEvaluator.for_surface(s)
    u, v = random_uv(np.random.default_rng(6), ev.parameter_range, 200)
    errs = compare_with_occ(ev, s, u, v)
    assert np.all(errs <= TOL), errs
    d = ev.differentials(u, v)
    # curvature scale 1/R = 0.5: rounding level, as above
    assert np.max(np.abs(d.K)) <= TOL * 0.25
    assert np.max(np.abs(np.abs(d.H) - 0.25)) <= TOL * 0.5


# ---------------------------------------------------------------------------- analytic surfaces
@needs_freecad
@pytest.mark.parametrize("mirror", [False, True])
def test_analytic_surfaces_match_occ(fc, mirror):
    rng = np.random.default_rng(7)
    for name, face in analytic_faces(fc):
        surface, prange = face_surface(face)
        if mirror:
            surface = mirrored(fc, surface)
        ev = SurfaceEvaluator.for_surface(surface, parameter_range=prange)
        assert ev.kind == name.split("_")[0], (name, ev.kind)
        if mirror and ev.analytic is not None:
            assert np.linalg.det(ev.analytic.frame) < 0, name
        # sample beyond the natural ranges too (periodic u, unbounded v of plane/cylinder/cone)
        u0, u1, v0, v1 = prange
        u = rng.uniform(u0 - 3, u1 + 3, 120)
        v = rng.uniform(v0, v1, 120) if name in ("sphere", "torus") else rng.uniform(v0 - 1, v1 + 1, 120)
        if name == "sphere":
            v = np.clip(v, -1.5, 1.5)  # stay off the poles for the curvature comparison
        if name == "cone_apex":
            v = np.abs(v) + 0.1  # stay off the apex
        errs = compare_with_occ(ev, surface, u, v)
        assert np.all(errs <= TOL), (name, errs)


@needs_freecad
def test_unit_sphere_and_cylinder_curvatures(fc):
    _, Part = fc
    rng = np.random.default_rng(8)
    ev = SurfaceEvaluator.for_face(Part.makeSphere(1.0).Faces[0])
    u, v = rng.uniform(0, 2 * math.pi, 500), rng.uniform(-1.5, 1.5, 500)
    d = ev.differentials(u, v)
    assert d.regular.all()
    # values of order one; rounding in the closed forms is ~1e-15
    assert np.max(np.abs(d.K - 1.0)) <= 1e-12
    assert np.max(np.abs(np.abs(d.H) - 1.0)) <= 1e-12
    # Forward sphere face: outward normal, so H = -1 (OCC's convention: e = n.S_uu < 0)
    assert np.max(np.abs(d.H + 1.0)) <= 1e-12
    assert np.max(np.abs(d.k1 - d.k2)) <= 1e-6  # umbilic everywhere (sqrt of rounding-level H^2 - K)
    ev = SurfaceEvaluator.for_face(Part.makeCylinder(2.0, 5.0).Faces[0])
    d = ev.differentials(rng.uniform(0, 6.3, 200), rng.uniform(0, 5, 200))
    assert np.max(np.abs(d.K)) <= 1e-12
    assert np.max(np.abs(d.H + 0.25)) <= 1e-12  # -1/(2R), outward normal
    assert np.max(np.abs(d.k2 + 0.5)) <= 1e-12 and np.max(np.abs(d.k1)) <= 1e-12


@needs_freecad
def test_torus_gaussian_curvature(fc):
    FreeCAD, Part = fc
    torus = Part.makeTorus(3.0, 1.0).Faces[0].copy()
    torus.Placement = placement(fc)
    ev = SurfaceEvaluator.for_face(torus)
    rng = np.random.default_rng(9)
    u, v = rng.uniform(0, 2 * math.pi, 500), rng.uniform(0, 2 * math.pi, 500)
    d = ev.differentials(u, v)
    big, r = 3.0, 1.0
    expected = np.cos(v) / (r * (big + r * np.cos(v)))
    assert np.max(np.abs(d.K - expected)) <= 1e-12  # values O(0.5), closed-form rounding
    # mean curvature of the outward-normal torus: -(R + 2 r cos v) / (2 r (R + r cos v))
    h_expected = -(big + 2 * r * np.cos(v)) / (2 * r * (big + r * np.cos(v)))
    assert np.max(np.abs(d.H - h_expected)) <= 1e-12


# ---------------------------------------------------------------------------- regularity
@needs_freecad
def test_sphere_poles_not_regular(fc):
    _, Part = fc
    ev = SurfaceEvaluator.for_face(Part.makeSphere(2.0).Faces[0])
    u = np.array([0.3, 2.0, 0.3, 2.0, 0.3])
    v = np.array([math.pi / 2, math.pi / 2, -math.pi / 2, -math.pi / 2, 0.4])
    d = ev.differentials(u, v)
    assert d.regular.tolist() == [False, False, False, False, True]
    assert np.all(np.isnan(d.H[:4])) and np.all(np.isnan(d.normal[:4]))
    assert np.all(d.J[:4] < 1e-12) and np.isfinite(d.H[4])


@needs_freecad
def test_collapsed_pole_row_not_regular(fc):
    FreeCAD, Part = fc
    rng = np.random.default_rng(10)
    apex = FreeCAD.Vector(0.5, 0.5, 2.0)
    poles = [[apex if i == 0 else FreeCAD.Vector(i, j + 0.1 * rng.random(), rng.random()) for j in range(5)]
             for i in range(5)]
    s = Part.BSplineSurface()
    s.buildFromPolesMultsKnots(poles, [4, 1, 4], [4, 1, 4], [0, 0.4, 1], [0, 0.6, 1], False, False, 3, 3)
    ev = SurfaceEvaluator.for_surface(s)
    v = np.linspace(0, 1, 7)
    d = ev.differentials(np.zeros_like(v), v)  # u = 0 is the collapsed row: S_v = 0
    assert not d.regular.any()
    d = ev.differentials(np.full_like(v, 0.3), v)
    assert d.regular.all()


def test_differentials_of_synthetic_paraboloid():
    """z = (a x^2 + b y^2)/2 at the origin: K = ab, H = (a+b)/2, no FreeCAD needed."""
    a, b = 0.7, -0.3
    n = 4
    su = np.tile([1.0, 0, 0], (n, 1))
    sv = np.tile([0, 1.0, 0], (n, 1))
    suu = np.tile([0, 0, a], (n, 1))
    svv = np.tile([0, 0, b], (n, 1))
    suv = np.zeros((n, 3))
    d = differential.surface_differentials((su, sv, suu, suv, svv), directions=True)
    assert np.allclose(d.K, a * b, rtol=0, atol=1e-15) and np.allclose(d.H, (a + b) / 2, rtol=0, atol=1e-15)
    assert np.allclose(d.k1, a) and np.allclose(d.k2, b)
    assert np.allclose(np.abs(d.dir1[:, 0]), 1.0) and np.allclose(np.abs(d.dir2[:, 1]), 1.0)
    r = differential.surface_differentials((su, sv, suu, suv, svv), orientation_sign=-1)
    assert np.allclose(r.H, -d.H) and np.allclose(r.K, d.K) and np.allclose(r.k1, -d.k2)
    bad = differential.surface_differentials((su, np.zeros((n, 3)), suu, suv, svv))
    assert not bad.regular.any() and np.all(np.isnan(bad.K))


def test_curvature_fields_on_components_match_the_formulas():
    """differential.curvature_fields (x, y, z rows) gives the module's formulas written with
    (n, 3) dot and cross products, NaN curvatures at non-regular points (a vanishing S_v, a
    NaN second derivative), and surface_differentials the same J, H, K with k1 >= k2."""
    rng = np.random.default_rng(11)
    n = 500
    su, sv, suu, suv, svv = (rng.standard_normal((n, 3)) for _ in range(5))
    sv[:3] = 0.0
    suu[5, 1] = np.nan
    c = differential.curvature_fields((su, sv, suu, suv, svv), orientation_sign=-1)
    cross = np.cross(su, sv)
    J = np.linalg.norm(cross, axis=1)
    E, F, G = (np.sum(a * b, 1) for a, b in ((su, su), (su, sv), (sv, sv)))
    reg = (J > 1e-10 * np.maximum(E, G)) & np.isfinite(suu).all(1)
    assert np.array_equal(c.regular, reg) and not reg[:3].any() and not reg[5]
    nrm = -cross / np.where(reg, J, 1.0)[:, None]
    e, f, g = (np.sum(nrm * a, 1) for a in (suu, suv, svv))
    D = np.where(reg, E * G - F * F, 1.0)
    np.testing.assert_allclose(c.J, J, rtol=1e-13)
    np.testing.assert_allclose(c.normal_xyz.T[reg], nrm[reg], rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(c.K[reg], ((e * g - f * f) / D)[reg], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(c.H[reg], ((e * G - 2 * f * F + g * E) / (2 * D))[reg], rtol=1e-9, atol=1e-12)
    assert np.all(np.isnan(c.K[~reg])) and np.all(np.isnan(c.H[~reg]))
    d = differential.surface_differentials((su, sv, suu, suv, svv), orientation_sign=-1)
    assert np.array_equal(d.K, c.K, equal_nan=True) and np.array_equal(d.H, c.H, equal_nan=True)
    assert np.all(d.k1[reg] >= d.k2[reg]) and np.allclose((d.k1 * d.k2)[reg], c.K[reg], rtol=1e-8, atol=1e-12)


def test_nurbs_data_pure_numpy_against_finite_differences():
    """Derivatives of an array-built rational surface against central differences."""
    rng = np.random.default_rng(11)
    knots_u = [0, 0, 0, 0, 0.3, 0.6, 0.6, 1, 1, 1, 1]
    knots_v = [0, 0, 0, 0.5, 1, 1, 1]
    data = NurbsSurfaceData(3, 2, knots_u, knots_v, rng.random((7, 4, 3)), 0.5 + rng.random((7, 4)))
    u, v = rng.uniform(0.05, 0.25, 20), rng.uniform(0.05, 0.45, 20)  # inside single spans
    s, su, sv, suu, suv, svv = data.derivatives(u, v)
    h = 1e-5
    # central differences: truncation O(h^2 |S'''|) ~ 1e-8 relative, rounding ~1e-16/h ~ 1e-11
    for got, fd in ((su, (data.points(u + h, v) - data.points(u - h, v)) / (2 * h)),
                    (sv, (data.points(u, v + h) - data.points(u, v - h)) / (2 * h)),
                    (suu, (data.derivatives(u + h, v)[1] - data.derivatives(u - h, v)[1]) / (2 * h)),
                    (suv, (data.derivatives(u + h, v)[2] - data.derivatives(u - h, v)[2]) / (2 * h)),
                    (svv, (data.derivatives(u, v + h)[2] - data.derivatives(u, v - h)[2]) / (2 * h))):
        assert np.max(np.abs(got - fd)) <= 1e-6 * np.max(np.abs(got))
    with pytest.raises(InputError):
        NurbsSurfaceData(3, 2, knots_u[:-1], knots_v, rng.random((7, 4, 3)))


def gauss_grids(data, rng, n, o=5):
    """n grids of o x o Gauss nodes, each inside one knot span of data (u (n, o), v (n, o))."""
    x = 0.5 * (np.polynomial.legendre.leggauss(o)[0] + 1.0)
    grids = []
    for knots in (data.uknots_distinct, data.vknots_distinct):
        k = rng.integers(0, knots.size - 1, n)
        grids.append(knots[k, None] + (knots[k + 1] - knots[k])[:, None] * x[None, :])
    return grids


@pytest.mark.parametrize("rational", [False, True])
def test_grid_evaluation_equals_pointwise(rational):
    """evaluate_grid on tensor grids (one knot span each; a few crossing knots, and periodic
    parameters outside the base period) gives evaluate's values at the broadcast points."""
    rng = np.random.default_rng(5)
    knots_u = [0, 0, 0, 0, 0.3, 0.6, 0.6, 1, 1, 1, 1]
    knots_v = [0, 0, 0, 0.5, 1, 1, 1]
    data = NurbsSurfaceData(3, 2, knots_u, knots_v, 10.0 * rng.random((7, 4, 3)),
                            0.5 + rng.random((7, 4)) if rational else None)
    u, v = gauss_grids(data, rng, 300)
    u[:20] = rng.uniform(0.0, 1.0, (20, 5))  # grids across knots: point by point inside
    v[20:40] = rng.uniform(0.0, 1.0, (20, 5))
    U = np.broadcast_to(u[:, :, None], (300, 5, 5)).ravel()
    V = np.broadcast_to(v[:, None, :], (300, 5, 5)).ravel()
    for order in (0, 1, 2):
        grid, point = data.evaluate_grid(u, v, order), data.evaluate(U, V, order)
        assert len(grid) == len(point) == (1, 3, 6)[order]
        for g, p in zip(grid, point):
            assert g.shape == p.shape
            np.testing.assert_allclose(g, p, rtol=0, atol=1e-12 * np.abs(p).max())
    periodic = NurbsSurfaceData(3, 2, knots_u, knots_v, data.poles, data.weights, uperiod=1.0)
    shifted = periodic.evaluate_grid(u[40:] + 2.0, v[40:])
    for g, p in zip(shifted, data.evaluate_grid(u[40:], v[40:])):
        np.testing.assert_allclose(g, p, rtol=0, atol=1e-12 * np.abs(p).max())
    with pytest.raises(InputError):
        data.evaluate_grid(u.ravel(), v.ravel())


@needs_freecad
def test_face_field_grid_equals_pointwise(fc):
    """FaceField.grid and area_element_grid give the pointwise fields (J, K, H, regular) of a
    trimmed B-spline face's grids, and the cubature's values at grid cells equal those of the
    same field without a grid method."""
    from hullprod_wb.brep.geometry.face_field import FaceField
    from hullprod_wb.brep.cubature.cells import CountedField
    _, Part = fc
    ff = FaceField(make_bspline(fc, rational=True).toShape())
    rng = np.random.default_rng(2)
    u, v = gauss_grids(ff.evaluator.nurbs, rng, 200)
    shape = (200, 5, 5)
    U, V = np.broadcast_to(u[:, :, None], shape).ravel(), np.broadcast_to(v[:, None, :], shape).ravel()
    grid, point = ff.grid(u, v), ff(U, V)
    for k in ("J", "K", "H"):
        np.testing.assert_allclose(grid[k], point[k], rtol=1e-10, atol=1e-12 * np.abs(point[k]).max())
    assert np.array_equal(grid["regular"], point["regular"])
    np.testing.assert_allclose(ff.area_element_grid(u, v)["J"], ff.area_element(U, V)["J"], rtol=1e-12)

    class Pointwise:  # the same field without grid()
        def __call__(self, u, v):
            return ff(u, v)
    a, b = CountedField(ff).grid(u, v), CountedField(Pointwise()).grid(u, v)
    for x, y in zip(a[:3], b[:3]):
        np.testing.assert_allclose(x, y, rtol=1e-10, atol=1e-12 * np.abs(y).max())


# ---------------------------------------------------------------------------- orientation, wrappers
@needs_freecad
def test_reversed_face_flips_h_keeps_k(fc):
    _, Part = fc
    face = Part.makeTorus(3.0, 1.0).Faces[0]
    rev = face.reversed()
    ev, er = SurfaceEvaluator.for_face(face), SurfaceEvaluator.for_face(rev)
    assert (ev.orientation_sign, er.orientation_sign) == (1, -1)
    rng = np.random.default_rng(12)
    u, v = rng.uniform(0, 6, 100), rng.uniform(0, 6, 100)
    d, r = ev.differentials(u, v, directions=True), er.differentials(u, v, directions=True)
    assert np.array_equal(r.H, -d.H) and np.array_equal(r.K, d.K)
    assert np.array_equal(r.normal, -d.normal)
    assert np.array_equal(r.k1, -d.k2) and np.array_equal(r.k2, -d.k1)
    # OCC's face normal follows the orientation too
    n_occ = np.array([tuple(rev.normalAt(a, b)) for a, b in zip(u[:10], v[:10])])
    assert np.max(np.abs(r.normal[:10] - n_occ)) <= 1e-12


@needs_freecad
def test_principal_directions_match_occ(fc):
    s = make_bspline(fc, rational=True)
    ev = SurfaceEvaluator.for_surface(s)
    u, v = random_uv(np.random.default_rng(13), ev.parameter_range, 100)
    d = ev.differentials(u, v, directions=True)
    assert np.allclose(np.linalg.norm(d.dir1, axis=1), 1) and np.allclose(np.linalg.norm(d.dir2, axis=1), 1)
    assert np.max(np.abs(np.einsum("ij,ij->i", d.dir1, d.normal))) <= 1e-12
    assert np.allclose(np.cross(d.dir1, d.dir2), d.normal, atol=1e-12)
    kmax = np.maximum(np.abs(d.k1), np.abs(d.k2))
    for i in range(len(u)):
        if d.k1[i] - d.k2[i] < 1e-3 * kmax[i]:
            continue  # near-umbilic: directions ill-conditioned
        dmax, dmin = s.curvatureDirections(float(u[i]), float(v[i]))
        assert abs(abs(np.dot(d.dir1[i], tuple(dmax))) - 1) <= 1e-8
        assert abs(abs(np.dot(d.dir2[i], tuple(dmin))) - 1) <= 1e-8


@needs_freecad
def test_for_face_kinds_wrappers_and_fallback(fc):
    FreeCAD, Part = fc
    box = Part.makeBox(1, 2, 3)
    kinds = {SurfaceEvaluator.for_face(f).kind for f in box.Faces}
    signs = {SurfaceEvaluator.for_face(f).orientation_sign for f in box.Faces}
    assert kinds == {"plane"} and signs == {1, -1}
    trimmed = Part.RectangularTrimmedSurface(make_bspline(fc), 0.2, 2.5, -0.5, 1.5)
    ev = SurfaceEvaluator.for_surface(trimmed)
    assert ev.kind == "bspline" and ev.parameter_range == (0.2, 2.5, -0.5, 1.5)
    curve = Part.BSplineCurve()
    curve.interpolate([FreeCAD.Vector(1, 0, 0), FreeCAD.Vector(1.5, 0, 1), FreeCAD.Vector(1.2, 0, 2),
                       FreeCAD.Vector(2, 0, 3)])
    for surface in (Part.SurfaceOfRevolution(curve, FreeCAD.Vector(0, 0, 0), FreeCAD.Vector(0, 0, 1)),
                    Part.SurfaceOfExtrusion(curve, FreeCAD.Vector(0.3, 1, 0.2))):
        u0, u1, v0, v1 = surface.bounds()
        face = surface.toShape(u0, u1, max(v0, -2.0) if v0 < -1e99 else v0, min(v1, 2.0) if v1 > 1e99 else v1)
        ev = SurfaceEvaluator.for_face(face)
        assert ev.kind == "occ:" + type(surface).__name__ and not ev.vectorised
        rng = np.random.default_rng(14)
        u0, u1, v0, v1 = ev.parameter_range
        u, v = rng.uniform(u0, u1, 30), rng.uniform(v0, v1, 30)
        errs = compare_with_occ(ev, face.Surface, u, v)
        assert np.all(errs <= TOL), errs
        ub, vb = ev.continuity_breaks()
        knots = np.array(curve.getKnots()[1:-1])
        assert np.allclose(ub if "Extrusion" in ev.kind else vb, knots)
    with pytest.raises(InputError):
        SurfaceEvaluator.for_face(box)
    with pytest.raises(InputError):
        SurfaceEvaluator.for_face(box.Faces[0]).derivatives(np.zeros(3), np.zeros(4))


@needs_freecad
def test_placed_and_located_faces(fc):
    """face.Surface carries the face's placement: B-spline and analytic faces moved after creation."""
    _, Part = fc
    rng = np.random.default_rng(17)
    faces = [make_bspline(fc, rational=True).toShape(), Part.makeSphere(2.0).Faces[0]]
    for face in faces:
        moved = face.copy()
        moved.Placement = placement(fc)
        ev = SurfaceEvaluator.for_face(moved)
        u, v = random_uv(rng, ev.parameter_range, 20)
        assert_matches_face_value(ev, moved, u, v)
        assert np.max(np.abs(ev.points(u, v) - SurfaceEvaluator.for_face(face).points(u, v))) > 1.0


@needs_freecad
def test_continuity_breaks(fc):
    ev = SurfaceEvaluator.for_surface(make_bspline(fc))  # u knots 0.7 (mult 1), 1.5 (mult 2); degree 3
    ub, vb = ev.continuity_breaks()
    assert ub.tolist() == [0.7, 1.5] and vb.tolist() == [0.2, 0.5]
    ub, vb = ev.continuity_breaks(min_continuity=2)  # mult > degree - 2
    assert ub.tolist() == [1.5] and vb.tolist() == [0.2, 0.5]  # v: degree 2, every knot is at most C1
    ub, _ = ev.continuity_breaks(urange=(0.5, 1.0))
    assert ub.tolist() == [0.7]
    per = SurfaceEvaluator.for_surface(make_periodic_bspline(fc), parameter_range=(-2.0, 7.5, 0.0, 1.0))
    ub, vb = per.continuity_breaks()
    assert np.allclose(ub, [-1.0, 0.0, 1.0, 2.0, 3.5, 4.0, 5.0, 6.0, 7.0]) and vb.size == 0
    assert all(b.size == 0 for b in SurfaceEvaluator.for_face(analytic_faces(fc)[1][1]).continuity_breaks())


# ---------------------------------------------------------------------------- public hulls
@needs_freecad
@pytest.mark.parametrize("name", ["catamaran_demihull.step", "dtmb5415_half_overture.igs",
                                  "kvlcc2_half_overture.igs", "series60_half_wavebem.iges",
                                  "wigley_half_wavebem.iges"])
def test_public_hull_faces_match_occ(fc, name):
    _, Part = fc
    shape = Part.read(shared_hull("brep/" + name))
    rng = np.random.default_rng(15)
    worst = np.zeros(5)
    for face in shape.Faces:
        ev = SurfaceEvaluator.for_face(face)
        assert ev.vectorised, ev.kind
        u, v = random_uv(rng, ev.parameter_range, 200)
        worst = np.maximum(worst, compare_with_occ(ev, face.Surface, u, v))
        assert_matches_face_value(ev, face, u[:10], v[:10])
    print("\n%s: max scaled errors S %.1e, D1 %.1e, D2 %.1e, H %.1e, K %.1e" % ((name,) + tuple(worst)))
    assert np.all(worst <= TOL), worst


# ---------------------------------------------------------------------------- timing
def test_timing_bicubic_100k_points():
    """Prints points per second (not asserted) for a 20 x 20 bicubic B-spline."""
    rng = np.random.default_rng(16)
    knots = np.r_[[0.0] * 3, np.linspace(0, 1, 18), [1.0] * 3]
    data = NurbsSurfaceData(3, 3, knots, knots, rng.random((20, 20, 3)) * 1000)
    u, v = rng.random(100_000), rng.random(100_000)
    data.derivatives(u[:1000], v[:1000])
    t0 = time.perf_counter()
    der = data.derivatives(u, v)
    t1 = time.perf_counter()
    differential.surface_differentials(der)
    t2 = time.perf_counter()
    print("\n100k points, bicubic 20x20 B-spline: derivatives %.3f s (%.2e pts/s), + H/K %.3f s (%.2e pts/s)"
          % (t1 - t0, 1e5 / (t1 - t0), t2 - t1, 1e5 / (t2 - t0)))
    assert all(np.all(np.isfinite(a)) for a in der)
