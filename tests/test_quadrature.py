"""Trimmed parameter domains and the adaptive boundary-fitted cubature
(eq:brep_surface_integral): analytic fields without FreeCAD, then faces made with Part and
the public hulls with a slow per-point OpenCascade field."""
import dataclasses
import math

import numpy as np
import pytest

from conftest import needs_freecad, shared_hull
from hullprod_wb.brep.cubature import GROUP_MIN_PATCHES, GROUPS, QUANTITIES, integrate, patch_groups
from hullprod_wb.brep.cubature import crossings as cub_crossings
from hullprod_wb.brep.cubature import cuts as cub_cuts
from hullprod_wb.brep.cubature import lines as cub_lines
from hullprod_wb.brep.cubature.cells import CellSet
from hullprod_wb.brep.geometry.pcurves import ConicArc2D, FunctionCurve2D, NurbsCurve2D
from hullprod_wb.brep.cubature.roots import solve_bracketed
from hullprod_wb.brep.geometry.trimmed_domain import TrimmedDomain
from hullprod_wb.core.errors import InputError

TAU_H, TAU_K = 1e-4, 1e-3


def field_of(J, K, H=None):
    """Vectorised field from callables J(u, v), K(u, v) (H = 1 unless given)."""
    def f(u, v):
        j = np.broadcast_to(J(u, v), u.shape).astype(float)
        h = np.ones_like(j) if H is None else np.broadcast_to(H(u, v), u.shape)
        return {"J": j, "K": np.broadcast_to(K(u, v), u.shape), "H": h,
                "regular": np.ones(u.shape, bool)}
    return f


UNIT_AREA = field_of(lambda u, v: 1.0, lambda u, v: 1.0)


# -- root finding and domains --------------------------------------------------------------


def test_solve_bracketed_reaches_machine_precision_and_survives_a_triple_root():
    n = 200
    r0 = 0.3 + 1e-3 * np.arange(n)
    a, b = r0 - 0.05, r0 + 0.07
    for f in (lambda x, i: (x - r0[i]) * (1 + x * x), lambda x, i: (x - r0[i]) ** 3):
        i = np.arange(n)
        r = solve_bracketed(f, a, b, f(a, i), f(b, i), 1e-14)
        # a simple root to ~1 ulp-scale; a triple root only to the bracket tolerance
        assert np.abs(r - r0).max() <= 1e-14


def test_polygon_intervals_are_exact():
    d = TrimmedDomain.polygon([(0, 0), (2, 0), (2, 1), (1, 2), (0, 1)])
    assert not d.is_rectangle
    idx, lo, hi = d.v_intervals(np.array([0.5, 1.5, 2.5]))
    assert list(idx) == [0, 1]
    np.testing.assert_allclose(lo, [0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(hi, [1.5, 1.5], rtol=1e-15)
    np.testing.assert_allclose(d.u_breakpoints(), [0.0, 1.0, 2.0], atol=1e-15)


def test_annulus_intervals_breakpoints_and_turning_points():
    d = TrimmedDomain.annulus((0.0, 0.0), 0.5, 1.0)
    u = np.array([0.0, 0.3, 0.7])
    idx, lo, hi = d.v_intervals(u)
    assert list(idx) == [0, 0, 1, 1, 2]
    ro, ri = np.sqrt(1 - u ** 2), np.sqrt(np.maximum(0.25 - u ** 2, 0))
    exp_lo = [-ro[0], ri[0], -ro[1], ri[1], -ro[2]]
    exp_hi = [-ri[0], ro[0], -ri[1], ro[1], ro[2]]
    # crossings are refined on the exact circles: parameter accuracy ~1e-15
    np.testing.assert_allclose(lo, exp_lo, atol=2e-15)
    np.testing.assert_allclose(hi, exp_hi, atol=2e-15)
    np.testing.assert_allclose(d.u_breakpoints(), [-1, -0.5, 0.5, 1], atol=1e-15)
    np.testing.assert_allclose(d.turning_u, [-1, -0.5, 0.5, 1], atol=1e-15)


def test_rectangle_is_recognised_and_v_lines_are_crossed():
    assert TrimmedDomain.rectangle(0, 2, -1, 1).is_rectangle
    d = TrimmedDomain.disc((0.0, 0.0), 1.0)
    np.testing.assert_allclose(d.v_line_crossings([0.6]), [-0.8, 0.8], atol=1e-15)


def test_open_loop_is_an_input_error():
    with pytest.raises(InputError, match="not closed"):
        TrimmedDomain([NurbsCurve2D.line((0, 0), (1, 0)), NurbsCurve2D.line((1, 0), (1, 1))])


def test_function_curve_domain():
    # ellipse (u/2)^2 + v^2 = 1 given by callables: area 2 pi
    c = FunctionCurve2D(lambda s: np.stack((2 * np.cos(s), np.sin(s)), 1),
                        lambda s: np.stack((-2 * np.sin(s), np.cos(s)), 1), 0.0, 2 * math.pi)
    r = integrate(TrimmedDomain.from_curves([c]), UNIT_AREA, TAU_H, TAU_K)
    assert r.values["A"] == pytest.approx(2 * math.pi, rel=1e-12)


# -- cubature of analytic fields -----------------------------------------------------------


@pytest.mark.parametrize("domain, area, rtol", [
    (TrimmedDomain.disc((0.3, -0.1), 0.7), math.pi * 0.49, 1e-4),
    (TrimmedDomain.annulus((0.0, 0.0), 0.5, 1.0), math.pi * 0.75, 1e-10),
    (TrimmedDomain.from_curves([ConicArc2D((0, 0), (1, 0), (0, 1), 2.0, 1.0)]), 2 * math.pi, 1e-4),
])
def test_boundary_fitted_area_is_exact(domain, area, rtol):
    r = integrate(domain, UNIT_AREA, TAU_H, TAU_K, rtol=rtol)
    # Strips bounded by the exact curves, cosine-clustered at the turning points: for a
    # disc or an ellipse alone the integrand is a trigonometric polynomial in the patch
    # parameters (exact at once); the annulus' outer strips are only analytic, so the
    # default 1e-4 leaves ~1e-7 there and a tighter rtol reaches the goal.
    assert r.values["A"] == pytest.approx(area, rel=1e-12)
    assert r.all_converged and r.recheck is None


def test_smooth_integrals_on_a_trimmed_domain():
    # J = 1 + u^2 v, K = 2 + u on the half disc v >= 0 of radius 1 (no class boundary)
    d = TrimmedDomain.from_curves([ConicArc2D((0, 0), (1, 0), (0, 1), 1.0, 1.0, 0.0, math.pi),
                                   NurbsCurve2D.line((-1, 0), (1, 0))])
    f = field_of(lambda u, v: 1 + u * u * v, lambda u, v: 2 + u)
    # smooth integrands converge with rtol: rtol 1e-10 for the 1e-12 comparison below
    r = integrate(d, f, TAU_H, TAU_K, rtol=1e-10)
    A = math.pi / 2 + 2.0 / 15.0  # int 1 + int u^2 v over the half disc
    assert r.values["A"] == pytest.approx(A, rel=1e-12)
    # int u (1 + u^2 v) vanishes by symmetry
    assert r.values["int_abs_K"] == pytest.approx(2 * A, rel=1e-12)
    assert r.values["int_K_plus"] == pytest.approx(2 * A, rel=1e-12)
    assert r.values["A_elliptic"] == pytest.approx(A, rel=1e-12)
    assert r.all_converged


def test_class_area_bounded_by_a_curved_threshold_line():
    # K = v - g(u), g = 0.3 + 0.1 sin(2 pi u), J = 1 + u v / 2 on the unit square:
    # elliptic where v > g + tau_K, saddle where v < g - tau_K.
    f = field_of(lambda u, v: 1 + 0.5 * u * v,
                 lambda u, v: v - 0.3 - 0.1 * np.sin(2 * np.pi * u))
    r = integrate(TrimmedDomain.rectangle(0, 1, 0, 1), f, TAU_H, TAU_K)

    def above(c):  # int_0^1 int_{g + c}^1 J dv du in closed form
        b = 0.3 + c
        return (1 - b) + 0.25 * (0.5 - b * b / 2 + 0.2 * b / (2 * np.pi) - 0.01 / 4)

    ell, sad = above(TAU_K), (1 + 0.125) - above(-TAU_K)
    # the line crossings are exact, the u direction smooth: far below rtol (goal 1e-8)
    assert r.values["A_elliptic"] == pytest.approx(ell, abs=1e-9)
    assert r.values["A_saddle"] == pytest.approx(sad, abs=1e-9)
    assert r.values["A_single"] == pytest.approx(1.125 - ell - sad, abs=1e-9)
    assert r.values["A"] == pytest.approx(1.125, rel=1e-13)
    assert r.converged["A_elliptic"] and r.converged["A_single"]


def test_patch_groups_cover_the_face_once():
    assert patch_groups(GROUP_MIN_PATCHES - 1) == [(0, GROUP_MIN_PATCHES - 1)]
    groups = patch_groups(1001)
    assert len(groups) == GROUPS and groups[0][0] == 0 and groups[-1][1] == 1001
    assert all(a[1] == b[0] for a, b in zip(groups[:-1], groups[1:]))
    assert max(b - a for a, b in groups) - min(b - a for a, b in groups) <= 1


def test_patch_groups_sum_to_the_whole_face_within_tolerance():
    # the curved threshold line of the test above, on 20 x 16 knot-line patches
    f = field_of(lambda u, v: 1 + 0.5 * u * v,
                 lambda u, v: v - 0.3 - 0.1 * np.sin(2 * np.pi * u))
    d = TrimmedDomain.rectangle(0, 1, 0, 1)
    ub, vb = np.linspace(0, 1, 21)[1:-1], np.linspace(0, 1, 17)[1:-1]
    whole = integrate(d, f, TAU_H, TAU_K, u_breaks=ub, v_breaks=vb)
    assert whole.n_initial_cells == 320
    parts = [integrate(d, f, TAU_H, TAU_K, u_breaks=ub, v_breaks=vb, patch_range=g) for g in patch_groups(320)]
    assert [p.n_initial_cells for p in parts] == [160, 160]
    assert all(p.all_converged for p in parts)
    for q in QUANTITIES:
        total = sum(p.values[q] for p in parts)
        assert abs(total - whole.values[q]) <= whole.tolerances[q] + sum(p.tolerances[q] for p in parts)
    assert sum(p.values["A"] for p in parts) == pytest.approx(1.125, rel=1e-13)
    with pytest.raises(InputError, match="holds none of the domain's 320 patches"):
        integrate(d, f, TAU_H, TAU_K, u_breaks=ub, v_breaks=vb, patch_range=(400, 500))


def test_class_areas_of_an_island_with_tangencies():
    # K = |x - c|^2 - R^2 inside the square: closed curves K = -+tau_K with vertical
    # tangents (square-root ends of the line integrals) inside cells
    c, R = np.array([0.53, 0.47]), 0.3
    f = field_of(lambda u, v: 1.0, lambda u, v: (u - c[0]) ** 2 + (v - c[1]) ** 2 - R * R)
    r = integrate(TrimmedDomain.rectangle(0, 1, 0, 1), f, TAU_H, TAU_K)
    rp, rm = R * R + TAU_K, R * R - TAU_K
    assert r.values["A_saddle"] == pytest.approx(math.pi * rm, abs=1e-8)
    assert r.values["A_single"] == pytest.approx(math.pi * (rp - rm), abs=1e-8)
    assert r.values["A_elliptic"] == pytest.approx(1 - math.pi * rp, abs=1e-8)
    # int |K| over the square: kinks on K = 0 resolved on the lines
    ring = math.pi * R ** 4 / 2  # int over the disc of R^2 - r^2
    inside = 2.0 / 3.0 - (c[0] + c[1]) + (c @ c) - R * R + 0.0  # int K over the square
    assert r.values["int_K_minus"] == pytest.approx(ring, rel=1e-9)
    assert r.values["int_K_plus"] - r.values["int_K_minus"] == pytest.approx(inside, rel=1e-9)


def test_flat_and_single_from_mean_curvature():
    # K = 0 everywhere: flat where |H| <= tau_H, single elsewhere; H = u - 0.4
    f = field_of(lambda u, v: 1.0, lambda u, v: 0.0, lambda u, v: u - 0.4)
    r = integrate(TrimmedDomain.rectangle(0, 1, 0, 2), f, TAU_H, TAU_K)
    assert r.values["A_flat"] == pytest.approx(2 * 2 * TAU_H, rel=1e-9)
    assert r.values["A_single"] == pytest.approx(2 - 4 * TAU_H, rel=1e-12)


def _flat_corner_reference(g, vH, tau_H, tau_K, J_inner):
    """Class areas on the unit square of K = v - g(u) and an H increasing in v that equals
    +-tau_H at v = vH(u, +-1): per u the flat set is the v interval where both bands
    overlap; integrated in u by scipy's quad, split at the corners (where a band edge of
    H meets one of K, found by brentq). J_inner(u, a, b) = int_a^b J dv."""
    from scipy.integrate import quad
    from scipy.optimize import brentq

    def flat(u):
        a = max(g(u) - tau_K, vH(u, -1))
        b = min(g(u) + tau_K, vH(u, +1))
        return J_inner(u, a, b) if b > a else 0.0

    corners = []
    for sk in (-1, 1):
        for sh in (-1, 1):
            h = lambda u: g(u) + sk * tau_K - vH(u, sh)
            grid = np.linspace(0.0, 1.0, 201)
            vals = [h(x) for x in grid]
            corners += [brentq(h, a, b, xtol=1e-15) for a, b, fa, fb in
                        zip(grid[:-1], grid[1:], vals[:-1], vals[1:]) if fa * fb < 0]
    pts = sorted(corners)
    A_flat = quad(flat, 0.0, 1.0, points=pts, epsabs=1e-15, epsrel=1e-13, limit=200)[0]
    band = quad(lambda u: J_inner(u, g(u) - tau_K, g(u) + tau_K), 0, 1, epsabs=1e-15, epsrel=1e-13)[0]
    above = quad(lambda u: J_inner(u, g(u) + tau_K, 1.0), 0, 1, epsabs=1e-15, epsrel=1e-13)[0]
    below = quad(lambda u: J_inner(u, 0.0, g(u) - tau_K), 0, 1, epsabs=1e-15, epsrel=1e-13)[0]
    return {"A_flat": A_flat, "A_single": band - A_flat, "A_elliptic": above, "A_saddle": below}, pts


def _mixed_cell(f, tau_H, tau_K, box=(0.0, 1.0, 0.0, 1.0), budget=np.inf):
    """The integrator of the unit square's patch (sigma = u, t = v), one cell of it,
    [s0, s1] x [t0, t1] = box, evaluated (CellSet) and its Interpolants from its four
    children's samples (used when within budget, a scalar or (1, 7))."""
    from hullprod_wb.brep.cubature.cells import child_cells
    from hullprod_wb.brep.cubature.driver import Integration
    it = Integration(TrimmedDomain.rectangle(0, 1, 0, 1), f, tau_H, tau_K, 5, 1e-4, 2, (), (), None)
    cell = it.evaluate(CellSet(np.array([0]), *(np.array([x]) for x in box)))
    ch = it.evaluate(child_cells(cell))
    return it, cell, cub_lines.interpolants(it.ls, cell, ch, np.ones(1, bool), cell, np.broadcast_to(budget, (1, 7)))


def _one_mixed_cell(f, tau_H, tau_K, box=(0.0, 1.0, 0.0, 1.0), budget=np.inf):
    """The integrator's units for one mixed cell (_mixed_cell): the integrator, the cell's
    MixedCells (on its interpolant when within budget, turned where that suits the level
    curves) and its first Pieces (the cell cut at the edge crossings)."""
    from hullprod_wb.brep.cubature.pieces import Pieces, cut_segments
    it, cell, interp = _mixed_cell(f, tau_H, tau_K, box, budget)
    mc = cub_lines.turn_cells(it.ls, cell, interp)
    ec, es = cub_cuts.edge_cuts(it.ls, mc)
    pc = Pieces.whole(*cut_segments(np.concatenate((mc.boxes.s0, es, mc.boxes.s1)),
                                    np.concatenate(([0], ec, [0]))))
    return it, mc, pc


@pytest.mark.parametrize("curved", [False, True])
def test_flat_region_corners_cut_the_lines(curved):
    """Where a level of H (H = +-tau_H) meets one of K (K = +-tau_K) the flat part of the
    band |K| <= tau_K begins or ends: the class areas' line integrals have a kink in sigma
    there, and a flat region narrower than the spacing of the lines may lie between them.
    The lines are cut at those corners (cuts.corner_cuts: found along the crossings
    of K = +-tau_K, refined on the interpolant by Newton): on a mixed cell that holds the
    four corners the cuts are at them to 1e-9 (straight bands: the whole square, whose first
    lines miss the flat region altogether; curved ones: a quarter-sized cell, Newton on
    degree-9 series), and the class areas match the reference to 1e-10."""
    tH, tK = 0.05, 0.02
    if curved:
        g = lambda u: 0.5 + 0.1 * np.sin(2 * np.pi * u)
        c1, c2 = 0.3, 0.2  # H = u - 0.4 + c1 (v - 0.5) + c2 (v - 0.5)^2, increasing in v on [0, 1]
        H = lambda u, v: u - 0.4 + c1 * (v - 0.5) + c2 * (v - 0.5) ** 2

        def vH(u, sign):  # the root of c2 w^2 + c1 w + (u - 0.4 - sign tH) = 0 with w = v - 0.5
            c = u - 0.4 - sign * tH  # on the branch where H increases; none: H above the level
            disc = c1 * c1 - 4 * c2 * c
            return 0.5 + (-c1 + math.sqrt(disc)) / (2 * c2) if disc >= 0 else -10.0
        J = lambda u, v: 1 + 0.5 * u * v
        J_inner = lambda u, a, b: (b - a) + 0.25 * u * (b * b - a * a)
        box = (0.25, 0.5, 0.5, 0.75)
    else:
        g = lambda u: 0.5 + 0.2 * (u - 0.5)
        H = lambda u, v: u - 0.4 + 0.3 * (v - 0.5)
        vH = lambda u, sign: 0.5 + (0.4 + sign * tH - u) / 0.3
        J = lambda u, v: 1.0
        J_inner = lambda u, a, b: b - a
        box = (0.0, 1.0, 0.0, 1.0)
    exact, corners = _flat_corner_reference(g, vH, tH, tK, J_inner)
    assert len(corners) == 4 and exact["A_flat"] > 1e-3
    f = field_of(J, lambda u, v: v - g(u), H)
    it, mc, pc = _one_mixed_cell(f, tH, tK, box)
    F, _, _, _, sig, count, _, ends, series = cub_lines.piece_values(it.ls, mc, pc)
    piece, at = cub_cuts.corner_cuts(it.ls, mc, pc, sig, count, ends, series)
    assert np.isnan(mc.width).all()  # not turned: sigma = u
    assert np.all((pc.sa[piece] < at) & (at < pc.sb[piece]))
    assert np.sort(at) == pytest.approx(corners, abs=1e-9)
    if not curved:
        assert F[:, 3].sum() == 0.0  # the lines alone: no flat area
    r = integrate(TrimmedDomain.rectangle(0, 1, 0, 1), f, tH, tK)
    assert r.all_converged
    for q, v in exact.items():
        assert r.values[q] == pytest.approx(v, abs=1e-10), q
        assert abs(r.values[q] - v) <= r.errors[q], q


@pytest.mark.parametrize("case", ["elliptic in saddle", "saddle in elliptic", "band in elliptic"])
def test_islands_that_no_line_meets_are_found(monkeypatch, case):
    """A small island of one class inside a mixed cell, between all of the cell's lines: the
    lines find none of it, but the cell's interpolant holds it. Where the interpolant's
    Bernstein bounds allow a part the lines miss, its extremum of K is searched and the
    piece through it cut (cuts.island_cuts): on the whole square as the cell, the
    first lines give the island's class no area and the cut goes through the island's
    centre; the next level's lines then meet the island. Class areas within 1e-9 of the
    closed form and within their error estimates, from the whole square as the first cell
    and from the default first cells (lines or search)."""
    from hullprod_wb.brep import cubature
    c = np.array([0.33, 0.61])
    r2 = lambda u, v: (u - c[0]) ** 2 + (v - c[1]) ** 2
    if case == "band in elliptic":
        tK = 1e-3
        K = lambda u, v: r2(u, v) + 0.5 * tK  # |K| <= tau_K where r^2 <= tau_K / 2
        exact = {"A_single": math.pi * 0.5 * tK, "A_elliptic": 1 - math.pi * 0.5 * tK, "A_saddle": 0.0}
        island = [3, 4]  # flat, single columns of the line integrals
    else:
        tK, R = 1e-6, 0.03
        sign = 1.0 if case == "elliptic in saddle" else -1.0
        K = lambda u, v: sign * (R * R - r2(u, v))
        inner, outer = math.pi * (R * R - tK), 1 - math.pi * (R * R + tK)
        exact = {"A_elliptic": inner, "A_saddle": outer} if sign > 0 else {"A_saddle": inner, "A_elliptic": outer}
        exact["A_single"] = 1 - inner - outer
        island = [5] if sign > 0 else [6]
    f = field_of(lambda u, v: 1.0, K)
    it, mc, pc = _one_mixed_cell(f, TAU_H, tK)
    F = cub_lines.piece_values(it.ls, mc, pc)[0]
    piece, at = cub_cuts.island_cuts(it.ls, mc, pc, F)
    assert mc.interp.use.all() and np.all(F[:, island] == 0.0)
    centre = c[1] if np.isfinite(mc.width[0]) else c[0]  # sigma of the cell: v where turned
    assert at.size >= 1 and at == pytest.approx(np.full(at.size, centre), abs=1e-9)
    for first_cells in (1, cubature.cells.MIN_INITIAL_CELLS):
        monkeypatch.setattr(cubature.cells, "MIN_INITIAL_CELLS", first_cells)
        r = integrate(TrimmedDomain.rectangle(0, 1, 0, 1), f, TAU_H, tK)
        for q, v in exact.items():
            assert r.values[q] == pytest.approx(v, abs=1e-9), q
            assert abs(r.values[q] - v) <= r.errors[q] + 1e-15, q
            assert r.converged[q], q


def test_integrable_corner_singularity_converges():
    # J = 1/r at the corner (0, 0) (area density of a cone-like parameterisation), K = 1:
    # int over [0, 1]^2 = 2 asinh(1); the quadtree refines towards the corner
    f = field_of(lambda u, v: 1.0 / np.maximum(np.hypot(u, v), 1e-300), lambda u, v: 1.0)
    r = integrate(TrimmedDomain.rectangle(0, 1, 0, 1), f, TAU_H, TAU_K, max_depth=14,
                  recheck=False)
    exact = 2 * math.asinh(1.0)
    assert r.converged["A"] and r.converged["int_abs_K"] and r.depth_reached > 5
    # the reported error estimate bounds the true error (estimates are conservative)
    assert abs(r.values["A"] - exact) <= r.errors["A"] <= 1e-4 * exact
    assert r.values["int_abs_K"] == pytest.approx(r.values["A"], rel=1e-15)
    assert r.peak_KJ[0, 0] < 1e-3 and r.peak_KJ[0, 1] < 1e-3  # largest |K| J at the corner
    # at the default depth the corner is not resolved, and that is reported
    r5 = integrate(TrimmedDomain.rectangle(0, 1, 0, 1), f, TAU_H, TAU_K)
    assert not r5.converged["A"] and r5.recheck is not None
    assert len(r5.unconverged_cells) and np.all(r5.unconverged_cells[:, [0, 2]] == 0.0)


def test_few_patches_start_from_halved_cells(monkeypatch):
    """An integration of fewer than MIN_INITIAL_CELLS patches starts from the patches halved
    in both directions (at most to level max_depth - 1); those levels count as done, so the
    deepest level stays max_depth, and the refinement sequence repeats the first cells'
    estimate for them. The integrals agree with those from the whole patch as the first
    cell to within the error estimates, here with fewer field points."""
    from hullprod_wb.brep import cubature
    assert cubature.cells.MIN_INITIAL_CELLS == 16
    c, R = np.array([0.53, 0.47]), 0.3
    f = field_of(lambda u, v: 1.0 + 0.2 * u * v, lambda u, v: (u - c[0]) ** 2 + (v - c[1]) ** 2 - R * R,
                 lambda u, v: 0.5 + 0.0 * u)
    d = TrimmedDomain.rectangle(0, 1, 0, 1)
    for max_depth, cells, level in ((5, 16, 2), (2, 4, 1), (1, 1, 0)):
        r = integrate(d, f, TAU_H, TAU_K, max_depth=max_depth, recheck=False)
        assert r.n_initial_cells == cells and r.depth_reached <= max_depth
        assert len(r.history) == r.depth_reached + 1
        assert all(h == r.history[0] for h in r.history[:level + 1])
    new = integrate(d, f, TAU_H, TAU_K)
    monkeypatch.setattr(cubature.cells, "MIN_INITIAL_CELLS", 1)
    old = integrate(d, f, TAU_H, TAU_K)
    assert old.n_initial_cells == 1 and new.all_converged and old.all_converged
    for q in QUANTITIES:
        assert abs(new.values[q] - old.values[q]) <= new.errors[q] + old.errors[q], q
    assert new.n_points < old.n_points


def test_oscillating_field_is_not_converged_at_depth_2():
    f = field_of(lambda u, v: 1.0, lambda u, v: 2 + np.sin(40 * u) * np.sin(40 * v))
    r = integrate(TrimmedDomain.rectangle(0, 1, 0, 1), f, TAU_H, TAU_K, max_depth=2)
    assert not r.converged["int_abs_K"] and r.converged["A"]
    assert r.depth_reached == 2 and r.unconverged_cells.shape[1] == 4
    assert len(r.unconverged_cells) > 0
    # the recheck continues one level deeper and is reported next to it
    assert r.recheck is not None and r.recheck.depth_reached == 3
    assert r.recheck.n_points > r.n_points


def test_nonregular_points_are_excluded_and_reported():
    def f(u, v):
        reg = np.hypot(u - 0.5, v - 0.5) > 0.2
        return {"J": np.ones_like(u), "K": np.where(reg, 1.0, np.nan), "H": np.ones_like(u),
                "regular": reg}
    r = integrate(TrimmedDomain.rectangle(0, 1, 0, 1), f, TAU_H, TAU_K, max_depth=2,
                  recheck=False)
    assert r.values["A"] == pytest.approx(1.0, rel=1e-12)
    # the valid area is the square less the disc of radius 0.2: 1 - 0.04 pi, within the
    # estimate the result reports (the disc's edge is resolved by the quadtree alone)
    exact = 1.0 - 0.04 * math.pi
    assert abs(r.values["A_valid"] - exact) <= r.errors["A_valid"] < 0.02
    assert abs(r.values["int_abs_K"] - exact) <= r.errors["int_abs_K"]  # K = 1 where valid
    assert r.n_nonregular > 0 and np.all(np.hypot(*(r.nonregular_uv - 0.5).T) <= 0.2)


def test_result_record_and_bad_input():
    r = integrate(TrimmedDomain.rectangle(0, 1, 0, 1), UNIT_AREA, TAU_H, TAU_K)
    d = r.to_dict()
    assert set(d["values"]) == set(QUANTITIES) and d["n_points"] == r.n_points > 0
    assert r.integrals().represented_area == pytest.approx(1.0)
    with pytest.raises(InputError):
        integrate("not a domain", UNIT_AREA, TAU_H, TAU_K)
    with pytest.raises(InputError, match="tau_K"):
        integrate(TrimmedDomain.rectangle(0, 1, 0, 1), UNIT_AREA, TAU_H, 0.0)
    with pytest.raises(InputError, match="sizes"):
        integrate(TrimmedDomain.rectangle(0, 1, 0, 1),
                  lambda u, v: {"J": np.ones(1), "K": u, "H": u, "regular": u > -1}, TAU_H, TAU_K)


# -- FreeCAD faces ---------------------------------------------------------------------------


def occ_field(face):
    """J, K, H of a face's surface, point by point from Surface.getDN (FreeCAD 0.20)."""
    s = face.Surface

    def f(u, v):
        D = np.empty((5, u.size, 3))
        for i, (a, b) in enumerate(zip(u.tolist(), v.tolist())):
            for k, (p, q) in enumerate(((1, 0), (0, 1), (2, 0), (1, 1), (0, 2))):
                d = s.getDN(a, b, p, q)
                D[k, i] = (d.x, d.y, d.z)
        su, sv, suu, suv, svv = D
        N = np.cross(su, sv)
        J = np.linalg.norm(N, axis=1)
        reg = J > 1e-12 * np.linalg.norm(su, axis=1) * np.linalg.norm(sv, axis=1)
        n = N / np.where(reg, J, 1.0)[:, None]
        E, F, G = (su * su).sum(1), (su * sv).sum(1), (sv * sv).sum(1)
        e, ff, g = (n * suu).sum(1), (n * suv).sum(1), (n * svv).sum(1)
        D2 = np.where(reg, E * G - F * F, 1.0)
        return {"J": J, "K": (e * g - ff * ff) / D2, "H": (e * G - 2 * ff * F + g * E) / (2 * D2),
                "regular": reg}
    return f


def occ_area_field(face):
    """J only (K = H = 1: no class boundaries), for represented-area checks."""
    full = occ_field(face)

    def f(u, v):
        J = full(u, v)["J"] if u.size else np.empty(0)
        return {"J": J, "K": np.ones_like(J), "H": np.ones_like(J),
                "regular": np.ones(J.shape, bool)}
    return f


@pytest.fixture(scope="module")
def fc():
    """FreeCAD's Part module and Vector."""
    from types import SimpleNamespace
    from hullprod_wb.freecad_env import import_freecad
    FreeCAD = import_freecad()
    import Part
    return SimpleNamespace(Part=Part, V=FreeCAD.Vector)


def green_area(face, n=2000):
    """Parameter area enclosed by the face's p-curves, independent of TrimmedDomain: the
    shoelace sum over fine OpenCascade samples of every wire child (oriented as its edge),
    Richardson-extrapolated from n and 2n samples (error ~ n^-4)."""
    def shoelace(m):
        total = 0.0
        for w in face.Wires:
            for e in w.childShapes():
                c, a, b = face.curveOnSurface(e)
                s = np.linspace(a, b, m)
                p = np.array([(q.x, q.y) for q in (c.value(float(x)) for x in s)])
                if e.Orientation == "Reversed":
                    p = p[::-1]
                total += 0.5 * np.sum(p[:-1, 0] * p[1:, 1] - p[1:, 0] * p[:-1, 1])
        return abs(total)
    return (4.0 * shoelace(2 * n) - shoelace(n)) / 3.0


@needs_freecad
def test_rectangular_plane_face(fc):
    Part = fc.Part
    face = Part.makePlane(4.0, 3.0)
    d = TrimmedDomain.from_face(face)
    assert d.is_rectangle
    r = integrate(d, occ_field(face), TAU_H, TAU_K)
    assert r.values["A"] == pytest.approx(12.0, rel=1e-14)
    assert r.values["A_flat"] == pytest.approx(12.0, rel=1e-14)


@needs_freecad
def test_plane_with_circular_hole(fc):
    Part, V = fc.Part, fc.V
    face = Part.makePlane(4.0, 3.0).cut(Part.makeCylinder(1.0, 10, V(2, 1.5, -5))).Faces[0]
    d = TrimmedDomain.from_face(face)
    assert not d.is_rectangle
    # the hole's strips are analytic, not polynomial: rtol 1e-10 for the exact comparison
    r = integrate(d, occ_area_field(face), TAU_H, TAU_K, rtol=1e-10)
    assert r.values["A"] == pytest.approx(12.0 - math.pi, rel=1e-13)


@needs_freecad
def test_disc_face_from_a_circle(fc):
    Part = fc.Part
    face = Part.Face(Part.Wire(Part.makeCircle(1.5)))
    r = integrate(TrimmedDomain.from_face(face), occ_area_field(face), TAU_H, TAU_K)
    assert r.values["A"] == pytest.approx(math.pi * 2.25, rel=1e-13)


@needs_freecad
def test_sphere_and_cylinder_faces_with_seams(fc):
    Part = fc.Part
    sphere = Part.makeSphere(2.0).Faces[0]  # seam twice, two degenerated edges at the poles
    d = TrimmedDomain.from_face(sphere)
    assert len(d.curves) == 4 and d.is_rectangle
    r = integrate(d, occ_field(sphere), 0.01, 0.01, rtol=1e-10)
    assert r.values["A"] == pytest.approx(16 * math.pi, rel=1e-12)
    assert r.values["int_abs_K"] == pytest.approx(4 * math.pi, rel=1e-12)
    assert r.values["A_elliptic"] == pytest.approx(16 * math.pi, rel=1e-12)
    cyl = Part.makeCylinder(2.0, 5.0).Faces[0]
    r = integrate(TrimmedDomain.from_face(cyl), occ_field(cyl), 0.01, 0.01)
    assert r.values["A"] == pytest.approx(20 * math.pi, rel=1e-12)
    assert r.values["A_single"] == pytest.approx(20 * math.pi, rel=1e-12)


@needs_freecad
def test_pcurve_conversion_and_occ_fallback(fc):
    from FreeCAD import Base
    from hullprod_wb.brep.geometry.pcurves import OccCurve2D, curve_from_geom2d
    G = fc.Part.Geom2d
    ellipse = G.Ellipse2d(Base.Vector2d(2, 0), Base.Vector2d(0, 1), Base.Vector2d(0.5, 0.2))
    for geom in (ellipse, G.Circle2d(Base.Vector2d(0.5, 0.2), 1.0)):
        exact = curve_from_geom2d(geom, 0.0, 2 * math.pi)
        assert not isinstance(exact, OccCurve2D)
        s = np.linspace(0.0, 2 * math.pi, 9)
        ref = np.array([(p.x, p.y) for p in (geom.value(float(x)) for x in s)])
        np.testing.assert_allclose(exact.value(s), ref, atol=1e-15)
    # point-by-point OpenCascade evaluation: the same domain, slower
    d = TrimmedDomain([OccCurve2D(G.Circle2d(Base.Vector2d(0.5, 0.2), 1.0), 0.0, 2 * math.pi)])
    idx, lo, hi = d.v_intervals(np.array([0.5, 1.1]))
    np.testing.assert_allclose(hi - lo, [2.0, 1.6], rtol=1e-14)


@needs_freecad
def test_bspline_face_trimmed_by_a_curve(fc):
    Part, V = fc.Part, fc.V
    # flat degree-1 B-spline (u, v) -> (2u, 3v, 0): J = 6, so area = 6 x parameter area;
    # the hole's p-curve is OpenCascade's own approximation of the projected circle
    flat = Part.BSplineSurface()
    flat.buildFromPolesMultsKnots([[V(0, 0, 0), V(0, 3, 0)], [V(2, 0, 0), V(2, 3, 0)]],
                                  [2, 2], [2, 2], [0, 1], [0, 1], False, False, 1, 1)
    face = flat.toShape().cut(Part.makeCylinder(0.6, 4, V(1.1, 1.4, -2))).Faces[0]
    d = TrimmedDomain.from_face(face)
    r = integrate(d, occ_area_field(face), TAU_H, TAU_K, rtol=1e-10)
    assert r.values["A"] == pytest.approx(6.0 * green_area(face), rel=1e-10)
    assert r.values["A"] == pytest.approx(6.0 - math.pi * 0.36, rel=1e-6)  # p-curve tolerance
    # curved B-spline surface trimmed the same way: against a fine non-adaptive rule
    poles = [[V(3 * i, 2 * j, 0.3 * math.sin(i + 2 * j)) for j in range(4)] for i in range(4)]
    s = Part.BSplineSurface()
    s.buildFromPolesMultsKnots(poles, [4, 4], [4, 4], [0, 1], [0, 1], False, False, 3, 3)
    face = s.toShape().cut(Part.makeCylinder(1.5, 10, V(4.2, 3.1, -5))).Faces[0]
    d = TrimmedDomain.from_face(face)
    assert not d.is_rectangle
    r = integrate(d, occ_area_field(face), TAU_H, TAU_K, rtol=1e-10)
    assert r.values["A"] == pytest.approx(fine_rule_area(d, occ_area_field(face)), rel=1e-9)


def fine_rule_area(domain, field, u_knots=(), v_knots=(), nu=96, nv=24):
    """Area by a fixed composite Gauss-Legendre rule: slabs between the domain's breakpoints
    and the u knots, each cut into equal parts with 24 points in u (endpoint-clustered by
    u = a + w (1 - cos)/2), and 24 Gauss points on every inside interval of each line
    (v_intervals), cut at the v knots."""
    bp = np.unique(np.concatenate((domain.u_breakpoints(), np.asarray(u_knots, float))))
    bp = bp[(bp >= domain.u_range[0]) & (bp <= domain.u_range[1])]
    vk = np.asarray(v_knots, float)
    x, w = np.polynomial.legendre.leggauss(nv)
    parts = max(1, nu // (len(bp) - 1))
    total = 0.0
    for a, b in zip(bp[:-1], bp[1:]):
        edges = np.linspace(0.0, 1.0, parts + 1)
        for e0, e1 in zip(edges[:-1], edges[1:]):
            th = np.pi * (e0 + (e1 - e0) * 0.5 * (x + 1))
            u = a + (b - a) * 0.5 * (1 - np.cos(th))
            du = (b - a) * 0.5 * np.pi * np.sin(th) * (e1 - e0) * 0.5 * w
            idx, lo, hi = domain.v_intervals(u)
            for i, l0, h0 in zip(idx, lo, hi):
                cuts = np.concatenate(([l0], vk[(vk > l0) & (vk < h0)], [h0]))
                c0, c1 = cuts[:-1], cuts[1:]
                vv = (c0[:, None] + (c1 - c0)[:, None] * 0.5 * (x + 1)[None, :]).ravel()
                J = field(np.full(vv.size, u[i]), vv)["J"].reshape(-1, nv)
                total += du[i] * float(np.sum(0.5 * (c1 - c0) * (J @ w)))
    return total


@needs_freecad
def test_kvlcc2_trimmed_face_domain(fc):
    Part = fc.Part
    shape = Part.read(shared_hull("brep/kvlcc2_half_overture.igs"))
    face = shape.Faces[0]  # corner face trimmed by a B-spline p-curve, gaps ~2e-7
    d = TrimmedDomain.from_face(face)
    assert not d.is_rectangle
    # the exact p-curves: crossings agree with OpenCascade's own curve values
    c = d.curves[int(np.argmax([getattr(k, "degree", 0) for k in d.curves]))]
    s = np.linspace(c.s0, c.s1, 7)
    pc = [k for k in (face.curveOnSurface(e) for e in face.OuterWire.childShapes())
          if type(k[0]).__name__ == "BSplineCurve2d" and k[0].Degree > 1][0][0]
    ref = np.array([(p.x, p.y) for p in (pc.value(float(x)) for x in s)])
    np.testing.assert_allclose(c.value(s), ref, atol=1e-14)
    s = face.Surface
    # J has kinks on the knot lines (cubic, 132 knot spans): both rules cut there
    r = integrate(d, occ_area_field(face), TAU_H, TAU_K, rtol=1e-8, u_breaks=s.getUKnots(),
                  v_breaks=s.getVKnots())
    # 48 slabs x 16 points in u, 16 points per v interval: ~1e-9 of the converged value
    ref = fine_rule_area(d, occ_area_field(face), s.getUKnots(), s.getVKnots(), nu=48, nv=16)
    assert r.values["A"] == pytest.approx(ref, rel=1e-8)
    assert r.values["A"] == pytest.approx(face.Area, rel=1e-3)  # OCC's GProp: ~1e-4 only


@needs_freecad
def test_dtmb5415_faces_represented_area(fc):
    Part = fc.Part
    shape = Part.read(shared_hull("brep/dtmb5415_half_overture.igs"))
    for face in shape.Faces:
        d = TrimmedDomain.from_face(face)
        assert d.is_rectangle
        s = face.Surface
        field = occ_area_field(face)
        # rtol 1e-4 leaves ~7e-8 here; rtol 1e-9 for the 1e-8 comparison
        r = integrate(d, field, TAU_H, TAU_K, rtol=1e-9, u_breaks=s.getUKnots(),
                      v_breaks=s.getVKnots())
        ref = knot_span_area(face, field)  # 16 x 16 Gauss points per knot span: ~3e-10
        assert r.values["A"] == pytest.approx(ref, rel=1e-8)
        assert r.values["A"] == pytest.approx(face.Area, rel=3e-4)


def knot_span_area(face, field, n=16, sub=1):
    """Tensor Gauss-Legendre (n x n) on every knot span split sub x sub times: a fixed,
    non-adaptive reference for the represented area of an untrimmed B-spline face."""
    s = face.Surface
    x, w = np.polynomial.legendre.leggauss(n)
    x, w = 0.5 * (x + 1), 0.5 * w

    def edges(k):
        k = np.asarray(k)
        return np.concatenate([np.linspace(a, b, sub + 1)[:-1] for a, b in zip(k[:-1], k[1:])]
                              + [k[-1:]])
    ue, ve = edges(s.getUKnots()), edges(s.getVKnots())
    u = (ue[:-1, None] + np.diff(ue)[:, None] * x).ravel()
    v = (ve[:-1, None] + np.diff(ve)[:, None] * x).ravel()
    wu = (np.diff(ue)[:, None] * w).ravel()
    wv = (np.diff(ve)[:, None] * w).ravel()
    U, Vv = np.meshgrid(u, v, indexing="ij")
    J = field(U.ravel(), Vv.ravel())["J"].reshape(U.shape)
    return float(wu @ J @ wv)


def test_refinement_history_ends_at_the_result():
    # K = v - g(u) as above: the level estimates of I_D-type integrals approach the result
    d = TrimmedDomain.rectangle(0.0, 1.0, 0.0, 1.0)
    f = field_of(lambda u, v: 1 + u * v / 2, lambda u, v: v - 0.3 - 0.1 * np.sin(2 * np.pi * u))
    r = integrate(d, f, TAU_H, TAU_K)
    h = r.history
    assert len(h) == r.depth_reached + 1 >= 2
    # converged: every cell is accepted, so the last level estimate is the result itself
    assert r.all_converged
    for q in QUANTITIES:
        assert h[-1][q] == pytest.approx(r.values[q], rel=1e-12, abs=1e-15)
    errs = [abs(x["int_abs_K"] - r.values["int_abs_K"]) for x in h]
    assert errs[-1] < errs[0]


def test_embedded_rule_is_exact_to_degree_n_minus_2():
    from hullprod_wb.brep.cubature.gauss_rules import embedded_weights as _embedded_weights, gauss_nodes as _gauss
    for n in (3, 5, 8):
        x, _ = _gauss(n)
        w = _embedded_weights(x)
        for k in range(n - 1):  # int_0^1 x^k = 1 / (k + 1)
            assert w @ x ** k == pytest.approx(1.0 / (k + 1), rel=1e-13)
        assert abs(w @ x ** (n - 1) - 1.0 / n) > 1e-8  # and not beyond (it is the lower rule)


def test_turned_lines_follow_level_curves_along_t():
    """The same field as test_class_area_bounded_by_a_curved_threshold_line with u and v
    exchanged: its level curves run along t. A mixed cell on its interpolant in this affine
    patch takes its lines along sigma (lines.turn_cells: sigma and t exchanged in its
    box and its interpolant, the constant strip width and du/dsigma kept), and so does a
    cell on lines of the field (evaluated with the axes exchanged back). On a cell that the curves cross from one t edge to the
    other, the turned lines meet no edge crossing (the lines not turned: four, each a cut)
    and give its class areas to 1e-14 within error estimates of 2e-9, where lines not turned,
    nearly parallel to the curves, are 1e-6 off and do not fit the cell's budget. The whole
    integration keeps the closed form to 1e-9."""
    from scipy.integrate import quad
    from hullprod_wb.brep.cubature.pieces import MixedCells
    f = field_of(lambda u, v: 1 + 0.5 * u * v,
                 lambda u, v: u - 0.3 - 0.1 * np.sin(2 * np.pi * v))
    u0, u1, v0, v1 = box = (0.25, 0.5, 0.0, 0.25)  # K = +-tau_K from (0.3, 0) to (0.4, 0.25)
    budget = np.array([[1e-6] * 3 + [1e-8] * 4])
    it, cell, interp = _mixed_cell(f, TAU_H, TAU_K, box, budget)
    assert interp.use.all()
    turned = cub_lines.turn_cells(it.ls, cell, interp)
    assert turned.width == pytest.approx([1.0]) and turned.du == pytest.approx([1.0])
    for a, b in (("s0", "t0"), ("s1", "t1"), ("t0", "s0"), ("t1", "s1")):
        assert getattr(turned.boxes, a) == getattr(cell, b), a
    assert np.array_equal(turned.interp.C, np.swapaxes(interp.C, 2, 3))
    on_field = cub_lines.turn_cells(it.ls, cell, dataclasses.replace(interp, use=np.zeros(1, bool)))
    assert on_field.width == pytest.approx([1.0]) and on_field.boxes.s0 == cell.t0
    plain = MixedCells(cell.boxes(), np.full(1, np.nan), np.full(1, np.nan), interp)

    def above(c):  # int over the cell where u > g(v) + c of J, g = 0.3 + 0.1 sin(2 pi v)
        g = lambda v: 0.3 + c + 0.1 * np.sin(2 * np.pi * v)
        inner = lambda v: (u1 - g(v)) + 0.25 * v * (u1 ** 2 - g(v) ** 2)
        return quad(inner, v0, v1, epsabs=1e-15, epsrel=1e-13)[0]

    total = (u1 - u0) * (v1 - v0) + 0.125 * (u1 ** 2 - u0 ** 2) * (v1 ** 2 - v0 ** 2)
    ell, sad = above(TAU_K), total - above(-TAU_K)
    exact = np.array([0.0, total - ell - sad, ell, sad])  # flat, single, elliptic, saddle
    assert cub_cuts.edge_cuts(it.ls, turned)[1].size == 0 and cub_cuts.edge_cuts(it.ls, plain)[1].size == 4
    val, err, fits, _ = cub_lines.integrate_lines(it.ls, turned, budget)
    assert np.abs(val[0, 3:] - exact).max() <= 1e-14 and err[0, 3:].max() <= 2e-9 and fits.all()
    # the turned lines of the field: the field evaluated with the axes exchanged back
    assert cub_cuts.edge_cuts(it.ls, on_field)[1].size == 0
    val, err, fits, _ = cub_lines.integrate_lines(it.ls, on_field, budget)
    assert np.all(np.abs(val[0, 3:] - exact) <= err[0, 3:]) and err[0, 3:].max() <= 2e-9 and fits.all()
    val, err, fits, _ = cub_lines.integrate_lines(it.ls, plain, budget)
    assert np.abs(val[0, 3:] - exact).max() > 1e-7 and not fits.any()
    assert np.all(np.abs(val[0, 3:] - exact) <= err[0, 3:])
    r = integrate(TrimmedDomain.rectangle(0, 1, 0, 1), f, TAU_H, TAU_K)

    def whole_above(c):  # int_0^1 int_{g + c}^1 J du dv in closed form
        b = 0.3 + c
        return (1 - b) + 0.25 * (0.5 - b * b / 2 + 0.2 * b / (2 * np.pi) - 0.01 / 4)

    ell, sad = whole_above(TAU_K), (1 + 0.125) - whole_above(-TAU_K)
    assert r.values["A_elliptic"] == pytest.approx(ell, abs=1e-9)
    assert r.values["A_saddle"] == pytest.approx(sad, abs=1e-9)
    assert r.values["A_single"] == pytest.approx(1.125 - ell - sad, abs=1e-9)
    assert r.all_converged


def _sign_change_field(a):
    """K = a (u - g(v)), g = 0.5 + 0.1 sin(2 pi v), J = H = 1 on the unit square: K changes
    sign inside the single band |K| <= TAU_K, and the closed forms
    int |K| = 0.255 a, int max(+-K, 0) = 0.1275 a, single area 2 TAU_K / a."""
    f = field_of(lambda u, v: 1.0, lambda u, v: a * (u - 0.5 - 0.1 * np.sin(2 * np.pi * v)))
    band = 2.0 * TAU_K / a
    exact = {"int_abs_K": 0.255 * a, "int_K_plus": 0.1275 * a, "int_K_minus": 0.1275 * a,
             "A_single": band, "A_elliptic": 0.5 - band / 2, "A_saddle": 0.5 - band / 2}
    return f, exact


def test_sign_changes_of_K_in_a_narrow_band_are_bounded_not_resolved(monkeypatch):
    """Where the band |K| <= tau_K is narrow (steep K), the lines are not cut at K = 0: a
    single piece where K changes sign takes the sign of its K integral and charges the
    bound tau_K A - |int K J| to the K integrals' error estimates, a small part of the
    tolerance. On lines of the field (crossings.crossings, lines.line_values) the crossings
    of K = 0 are then neither refined nor counted, the lines where K changes sign are
    marked and charged, and their |K| integral stays within the charge of the closed
    form; resolving K = 0 (as refine_to does once the charges would not fit) refines them
    too, 5 more crossings on top of 12 and more field points, and gives the closed form to
    1e-9 with no charge. The values of the whole integration stay within that bound of the
    closed form (4e-8 relative here: the band's halves cancel on every line, the worst
    case); resolving K = 0 (share 0) gives the K integrals' closed form to 1e-10. Class
    areas: 1e-9 in both."""
    from scipy.integrate import quad
    from hullprod_wb.brep import cubature
    f, exact = _sign_change_field(10.0)
    it, mc, _ = _one_mixed_cell(f, TAU_H, TAU_K, budget=0.0)  # lines on the field
    assert not mc.interp.use.any() and not it.ls.resolve_zero
    sig = np.array([0.45, 0.5, 0.55, 0.7])  # lines u = sig; K changes sign on the first three
    zero, cell, t0, t1 = sig < 0.6, np.zeros(sig.size, int), np.zeros(sig.size), np.ones(sig.size)
    line = [quad(lambda v: abs(10.0 * (s - 0.5 - 0.1 * np.sin(2 * np.pi * v))), 0.0, 1.0, epsabs=1e-15,
                 points=[1 / 12, 5 / 12, 7 / 12, 11 / 12], limit=200)[0] for s in sig]  # int |K| dv
    refined, points = [], []
    for resolve in (False, True):
        ls = dataclasses.replace(it.ls, resolve_zero=resolve)
        n0 = it.f.n_points
        _, level, _, S = cub_crossings.crossings(ls, cub_crossings.line_segments(ls, mc, cell, cell, sig)[0])
        points.append(it.f.n_points - n0)
        refined.append(level.size)
        assert np.array_equal(S.zero, zero) and np.any(level == 4) == resolve
        d = cub_lines.line_values(ls, mc, cell, cell, sig, t0, t1)
        assert np.array_equal(d.crossings.count[:, 4] > 0, zero & resolve)
        if resolve:
            assert not d.C.any()
            assert d.F[:, 0] == pytest.approx(line, abs=1e-9)
        else:
            assert np.array_equal(d.C > 0.0, zero)
            assert np.all(np.abs(d.F[:, 0] - line) <= d.C + 1e-15)
            assert np.all(d.E[:, 0] >= d.C)
    assert refined == [12, 17] and points[0] < points[1]
    r = integrate(TrimmedDomain.rectangle(0, 1, 0, 1), f, TAU_H, TAU_K)
    assert not r.zero_resolved and r.zero_charge > 0.0
    assert r.zero_charge <= cubature.driver.ZERO_CHARGE_SHARE * r.tolerances["int_abs_K"]
    assert r.all_converged
    for q in ("int_abs_K", "int_K_plus", "int_K_minus"):
        # the bound holds: the error of |K| is at most the charge, of K+ and K- half of it
        part = 1.0 if q == "int_abs_K" else 0.5
        assert abs(r.values[q] - exact[q]) <= part * r.zero_charge <= r.errors[q], q
        assert r.values[q] == pytest.approx(exact[q], rel=1e-7), q
    for q in ("A_single", "A_elliptic", "A_saddle"):
        assert r.values[q] == pytest.approx(exact[q], abs=1e-9), q
    monkeypatch.setattr(cubature.driver, "ZERO_CHARGE_SHARE", 0.0)
    s = integrate(TrimmedDomain.rectangle(0, 1, 0, 1), f, TAU_H, TAU_K)
    assert s.zero_resolved and s.zero_charge == 0.0 and s.all_converged
    for q, v in exact.items():
        assert s.values[q] == pytest.approx(v, rel=1e-10, abs=1e-9 if q.startswith("A_") else 0.0), q


def test_sign_changes_of_K_in_a_wide_band_are_resolved():
    """Where the bound for K = 0 would not fit the K integrals' tolerance (a wide band
    |K| <= tau_K: small K), the integration resolves K = 0 instead: the K integrals and
    class areas converge to the closed form within their error estimates (5e-8 relative,
    6e-7 absolute here, at rtol 1e-4)."""
    f, exact = _sign_change_field(0.01)
    r = integrate(TrimmedDomain.rectangle(0, 1, 0, 1), f, TAU_H, TAU_K)
    assert r.zero_resolved and r.zero_charge == 0.0 and r.all_converged
    for q, v in exact.items():
        assert abs(r.values[q] - v) <= r.errors[q], q
        assert r.values[q] == pytest.approx(v, rel=1e-7, abs=1e-6 if q.startswith("A_") else 0.0), q


def test_prefetched_first_levels_give_the_same_integrals(monkeypatch):
    """Field values of the first two quadtree levels evaluated before the thresholds are
    known (NodePrefetch: none, the patches, the patches and their children) are taken over by
    the integration: the same values and errors to the bit, and the integration itself calls
    the field only for the levels not prefetched. A prefetch of another order is refused."""
    from hullprod_wb.brep.cubature import NodePrefetch
    calls = []

    def f(u, v):
        calls.append(u.size)
        return {"J": 1 + 0.5 * u * v, "K": v - 0.3 - 0.1 * np.sin(2 * np.pi * u), "H": 0.5 + 0 * u,
                "regular": np.ones(u.shape, bool)}
    d = TrimmedDomain.disc((0.0, 0.0), 1.0)
    plain = integrate(d, f, TAU_H, TAU_K)
    own = []
    from hullprod_wb.brep import cubature
    monkeypatch.setattr(cubature.cells, "PREFETCH_CELLS", 3)  # the first cells, then their children
    n0 = NodePrefetch(d, f, 5).cells[0].size
    s0, s1 = -(-n0 // 3), -(-4 * n0 // 3)  # steps of each level
    for levels, steps in ((0, 0), (1, s0), (2, s0 + s1)):
        p = NodePrefetch(d, f, 5)
        for k in range(steps):
            assert p.step() == (k < s0 + s1 - 1)
        assert len(p.values) == levels
        calls.clear()
        r = integrate(d, f, TAU_H, TAU_K, prefetch=p)
        own.append(sum(calls))
        assert r.values == plain.values and r.errors == plain.errors
        assert r.n_points == plain.n_points  # nothing accepted on its own here: nothing in vain
    assert own[0] == plain.n_points and own[0] > own[1] > own[2]
    p = NodePrefetch(d, f, 4)
    with pytest.raises(InputError, match="prefetched"):
        integrate(d, f, TAU_H, TAU_K, prefetch=p)
    p = NodePrefetch(d, f, 5, max_depth=2)  # first cells of another max_depth
    assert p.cells[0].size < n0
    with pytest.raises(InputError, match="prefetched"):
        integrate(d, f, TAU_H, TAU_K, prefetch=p)


def test_mixed_cells_on_interpolants_agree_with_field_lines(monkeypatch):
    """The lines of mixed cells run on a local tensor interpolant of the cell's samples when
    it is accurate enough; forcing the field everywhere (share 0) gives the same integrals
    to well within the tolerance, with several times more field evaluations."""
    from hullprod_wb.brep import cubature
    c, R = np.array([0.53, 0.47]), 0.3
    f = field_of(lambda u, v: 1.0 + 0.2 * u * v, lambda u, v: (u - c[0]) ** 2 + (v - c[1]) ** 2 - R * R,
                 lambda u, v: 0.5 + 0.0 * u)
    d = TrimmedDomain.rectangle(0, 1, 0, 1)
    fast = integrate(d, f, TAU_H, TAU_K)
    monkeypatch.setattr(cubature.lines, "INTERPOLANT_SHARE", 0.0)
    slow = integrate(d, f, TAU_H, TAU_K)
    for q in QUANTITIES:
        # both converged at rtol 1e-4; their difference is far below it
        assert fast.values[q] == pytest.approx(slow.values[q], rel=1e-7, abs=1e-9), q
    assert fast.all_converged and slow.all_converged
    assert fast.n_points * 3 < slow.n_points


def test_patch_rule_bounds_its_error():
    from hullprod_wb.brep.cubature import patch_rule
    d = TrimmedDomain.disc((0.0, 0.0), 1.0)
    f = field_of(lambda u, v: np.exp(u) * (1 + v * v), lambda u, v: 1.0 + 0.0 * u)
    # int over the unit disc of e^u (1 + v^2), by scipy in polar coordinates
    from scipy import integrate as si
    exact = si.dblquad(lambda r, t: np.exp(r * np.cos(t)) * (1 + (r * np.sin(t)) ** 2) * r,
                       0, 2 * np.pi, 0, 1, epsabs=1e-13, epsrel=1e-13)[0]
    cuts = np.linspace(-1.0, 1.0, 9)[1:-1]
    errors = []
    for order, u_breaks in ((5, ()), (8, ()), (8, cuts), (12, cuts)):
        vals, bound = patch_rule(d, f, order, u_breaks)
        err = abs(vals["A"] - exact)
        assert err <= bound["A"], (order, len(u_breaks))  # the embedded bound holds
        errors.append(err)
    # and the rule converges with order and with smaller patches (measured 1e-2, 6e-6,
    # 3e-13, 0)
    assert errors[1] < 1e-3 * errors[0] and errors[2] < 1e-10 * exact and errors[3] < 1e-12 * exact
    with pytest.raises(InputError):
        patch_rule(d, f, 2)
    # the area alone (the backend's area cross-check): the same rule, J evaluated only
    from hullprod_wb.brep.cubature import patch_area
    for order, u_breaks in ((5, ()), (8, cuts)):
        vals, bound = patch_rule(d, f, order, u_breaks)
        area, area_bound = patch_area(d, f, order, u_breaks)
        assert area == pytest.approx(vals["A"], rel=1e-14)
        assert area_bound == pytest.approx(bound["A"], rel=1e-6, abs=1e-15 * exact)
    nan_at_centre = field_of(lambda u, v: np.where(u * u + v * v < 1e-4, np.nan, 1.0), lambda u, v: 1.0 + 0.0 * u)
    assert patch_area(d, nan_at_centre, 8)[0] == pytest.approx(patch_rule(d, nan_at_centre, 8)[0]["A"], rel=1e-14)
    with pytest.raises(InputError):
        patch_area(d, f, 2)


def test_segment_series_roots_and_exact_integrals():
    """A segment of an interpolant is a Legendre series in its local coordinate: its power
    form matches numpy's, Newton on it finds the level crossings to machine precision (a
    simple root and both roots of a near-double pair), and the integrals of J and K J over
    pieces are exact against numpy's polynomial antiderivatives."""
    from numpy.polynomial import legendre as leg
    from numpy.polynomial import polynomial as poly
    from hullprod_wb.brep.cubature.cell_interpolant import SegmentField, monomial_matrix
    deg = 9
    M = monomial_matrix(deg)
    for k in range(deg + 1):
        p = leg.leg2poly(np.eye(deg + 1)[k])
        assert np.allclose(M[k, :p.size], p, atol=1e-13) and not M[k, p.size:].any()
    rng = np.random.default_rng(3)
    # one cell on [0, 2] x [1, 3]; segments t = fixed along sigma (axis "sigma")
    cells = CellSet(np.zeros(1, int), np.array([0.0]), np.array([2.0]), np.array([1.0]), np.array([3.0]))
    C = rng.normal(size=(1, 3, deg + 1, deg + 1)) / (1.0 + np.arange(deg + 1))[None, None, :, None] ** 2
    # K's series along every segment: chosen below through the fixed t's coefficients
    seg = SegmentField(C, np.array([True]), cells, np.zeros(3, int), np.array([1.5, 2.0, 2.5]), "sigma",
                       fallback=None)
    z = np.linspace(-1, 1, 7)
    for s in range(3):
        for row in range(3):
            ref = leg.legval(z, seg.coef[s, row])
            assert np.allclose(poly.polyval(z, seg.power[s, row]), ref, rtol=1e-12, atol=1e-12)
    # every segment at common fractions of its range (one product), as point by point; the
    # segments of a cell without interpolant (use False) through the fallback, at the same x
    zs = np.array([0.02, 0.3, 0.5, 0.97])
    J, K, H, reg = seg.samples(zs)
    pJ, pK, pH, preg = seg(np.tile(2.0 * zs, 3), np.repeat(np.arange(3), zs.size))  # sigma in [0, 2]
    for a, b in ((J, pJ), (K, pK), (H, pH)):
        assert np.allclose(a, b, rtol=1e-13, atol=1e-13)
    assert reg.all() and preg.all()
    seen = []

    def fallback(x, i):
        seen.append((x.copy(), i.copy()))
        return x, 2.0 * x, 3.0 * x, x < 1.5

    mixed = SegmentField(C, np.array([False]), cells, np.zeros(2, int), np.array([1.5, 2.5]), "sigma",
                         fallback=fallback)
    J, K, H, reg = mixed.samples(zs)
    xs = np.tile(2.0 * zs, 2)
    assert np.array_equal(seen[0][0], xs) and np.array_equal(seen[0][1], np.repeat([0, 1], zs.size))
    assert np.array_equal(J, xs) and np.array_equal(K, 2.0 * xs) and np.array_equal(reg, xs < 1.5)
    # K along segment 0 replaced by (z - 0.3)(z + 0.5)(z - 0.3 - 1e-7) + 0: roots 0.3, -0.5,
    # 0.3 + 1e-7 in z, i.e. x = 1 + z
    target = poly.polyfromroots([0.3, -0.5, 0.3 + 1e-7])
    seg.power[0, 1] = 0.0
    seg.power[0, 1, :target.size] = target
    x = lambda zz: 1.0 + zz
    a = np.array([x(0.1), x(-0.9), x(0.3 + 5e-8)])
    b = np.array([x(0.3 + 5e-8), x(0.0), x(0.6)])
    fa, fb = poly.polyval(a - 1.0, target), poly.polyval(b - 1.0, target)
    assert np.all(fa * fb < 0)
    r = seg.roots(np.zeros(3, int), 1, np.zeros(3), a, b, fa, fb, 2e-12)
    # the simple root to rounding; the pair 1e-7 apart (slope 8e-8 there) to its
    # conditioning, each in its own bracket
    assert r[1] == pytest.approx(x(-0.5), abs=1e-15)
    assert r[[0, 2]] == pytest.approx([x(0.3), x(0.3 + 1e-7)], abs=1e-9)
    assert r[0] < x(0.3 + 5e-8) < r[2]
    # a level offset: K - c = 0
    c = poly.polyval(0.2, target)
    r = seg.roots(np.zeros(1, int), 1, np.array([c]), np.array([x(0.0)]), np.array([x(0.25)]),
                  np.array([poly.polyval(0.0, target) - c]), np.array([poly.polyval(0.25, target) - c]), 2e-12)
    assert r == pytest.approx([x(0.2)], abs=1e-12)
    # exact integrals over pieces [a, b] in x (z = x - 1, dx = dz)
    pa, pb = np.array([0.0, 0.3, 1.9]), np.array([2.0, 1.2, 1.95])
    sid = np.array([1, 2, 2])
    IJ, IKJ = seg.integrals(sid, pa, pb)
    for k, s in enumerate(sid):
        Jp, Kp = seg.power[s, 0], seg.power[s, 1]
        A, B = poly.polyint(Jp), poly.polyint(poly.polymul(Kp, Jp))
        za, zb = pa[k] - 1.0, pb[k] - 1.0
        assert IJ[k] == pytest.approx(poly.polyval(zb, A) - poly.polyval(za, A), rel=1e-12, abs=1e-13)
        assert IKJ[k] == pytest.approx(poly.polyval(zb, B) - poly.polyval(za, B), rel=1e-11, abs=1e-13)
    # the least value over a window (tangency search): sign (H - offset) on every segment
    seg.power[:, 2] = 0.0
    seg.power[:, 2, :3] = [0.04 - 0.01, -0.4, 1.0]  # (z - 0.2)^2 - 0.01
    low = seg.window_min(np.full(3, 2), np.array([0.0, 0.5, 0.0]), np.array([1.0, 1.0, -1.0]),
                         x(np.array([-0.5, -0.5, -0.5])), x(np.array([0.9, 0.9, 0.9])))
    assert low[0] == pytest.approx(-0.01, abs=1e-14)
    assert low[1] == pytest.approx(-0.51, abs=1e-14)
    assert low[2] == pytest.approx(-((0.9 - 0.2) ** 2 - 0.01), abs=1e-14)  # -p: least at the far end


def test_tangency_points_by_newton_on_the_cell_interpolant():
    """A level curve g = c of a cell's interpolant touches a line sigma = const where g = c
    and dg/dt = 0: Newton on that pair finds the point to rounding; a start whose Newton
    path leaves the box gives NaN (the caller's bracketed search takes it)."""
    from hullprod_wb.brep.cubature.cell_interpolant import monomial_matrix, tangency_points
    deg = 9
    Minv = np.linalg.inv(monomial_matrix(deg))
    # K(x, y) = (y - 0.2)^2 - 0.5 (x - 0.1) + 0.3 x y^3 in local coordinates (x, y) in [-1, 1]^2:
    # with c = 0, tangent to x = const where 2 (y - 0.2) + 0.9 x y^2 = 0 and K = 0
    D = np.zeros((deg + 1, deg + 1))
    D[0, 0], D[0, 1], D[0, 2] = 0.04 + 0.05, -0.4, 1.0
    D[1, 0], D[1, 3] = -0.5, 0.3
    C = np.zeros((1, 3, deg + 1, deg + 1))
    C[0, 1] = Minv.T @ D @ Minv  # D = M^T C M
    cells = CellSet(np.zeros(1, int), np.array([0.0]), np.array([4.0]), np.array([1.0]), np.array([2.0]))
    sig = lambda x: 2.0 * (x + 1.0)
    t = lambda y: 1.0 + 0.5 * (y + 1.0)
    one = np.zeros(1, int)
    r = tangency_points(C, cells, one, np.array([1]), np.zeros(1), np.array([sig(-0.5)]), np.array([sig(0.9)]),
                        np.array([t(-0.9)]), np.array([t(0.9)]), np.array([sig(0.3)]), np.array([t(0.3)]), 1e-13)
    x = (r[0] / 2.0) - 1.0
    # solve the pair independently: y from 2 (y - 0.2) + 0.9 x y^2 = 0, then K = 0
    from scipy.optimize import fsolve
    xs, ys = fsolve(lambda p: [(p[1] - 0.2) ** 2 - 0.5 * (p[0] - 0.1) + 0.3 * p[0] * p[1] ** 3,
                               2 * (p[1] - 0.2) + 0.9 * p[0] * p[1] ** 2], [0.2, 0.2], xtol=1e-13)
    assert x == pytest.approx(xs, abs=1e-12)
    # with an offset: K - c = 0 moves the tangency (to x = 0.1 - 2 c, y = 0.2, without the cubic term)
    D2 = D.copy()
    D2[1, 3] = 0.0
    C[0, 2] = Minv.T @ D2 @ Minv
    c = 0.05
    r = tangency_points(C, cells, one, np.array([2]), np.array([c]), np.array([sig(-0.5)]), np.array([sig(0.9)]),
                        np.array([t(-0.9)]), np.array([t(0.9)]), np.array([sig(0.0)]), np.array([t(0.0)]), 1e-13)
    assert r[0] == pytest.approx(sig(0.1 - 2 * c), abs=1e-12)
    # a box that excludes the tangency: NaN
    r = tangency_points(C, cells, one, np.array([2]), np.array([c]), np.array([sig(0.5)]), np.array([sig(0.9)]),
                        np.array([t(-0.9)]), np.array([t(0.9)]), np.array([sig(0.7)]), np.array([t(0.0)]), 1e-13)
    assert np.isnan(r[0])


def test_level_intersections_by_newton_on_the_cell_interpolant():
    """Two level curves of a cell's interpolant (a level of H and one of K) meet where both
    equations hold: Newton on the pair finds the point to rounding, against fsolve; a box
    that excludes it gives NaN."""
    from scipy.optimize import fsolve
    from hullprod_wb.brep.cubature.cell_interpolant import level_intersections, monomial_matrix
    deg = 9
    Minv = np.linalg.inv(monomial_matrix(deg))
    # K = y - 0.1 - 0.2 x^2 + 0.05 x y^3, H = x + 0.3 y + 0.2 y^2 in local coordinates
    DK, DH = np.zeros((deg + 1, deg + 1)), np.zeros((deg + 1, deg + 1))
    DK[0, 1], DK[0, 0], DK[2, 0], DK[1, 3] = 1.0, -0.1, -0.2, 0.05
    DH[1, 0], DH[0, 1], DH[0, 2] = 1.0, 0.3, 0.2
    C = np.zeros((1, 3, deg + 1, deg + 1))
    C[0, 1], C[0, 2] = Minv.T @ DK @ Minv, Minv.T @ DH @ Minv
    cells = CellSet(np.zeros(1, int), np.array([0.0]), np.array([4.0]), np.array([1.0]), np.array([2.0]))
    sig = lambda x: 2.0 * (x + 1.0)
    t = lambda y: 1.0 + 0.5 * (y + 1.0)
    one = np.zeros(1, int)
    cK, cH = 0.02, -0.05  # K = 0.02 meets H = -0.05
    r = level_intersections(C, cells, one, np.array([2]), np.array([cH]), np.array([1]), np.array([cK]),
                            np.array([sig(-0.9)]), np.array([sig(0.9)]), np.array([t(-1.0)]), np.array([t(1.0)]),
                            np.array([sig(0.0)]), np.array([t(0.0)]), 1e-13)
    xs, ys = fsolve(lambda p: [p[1] - 0.1 - 0.2 * p[0] ** 2 + 0.05 * p[0] * p[1] ** 3 - cK,
                               p[0] + 0.3 * p[1] + 0.2 * p[1] ** 2 - cH], [0.0, 0.0], xtol=1e-14)
    assert r[0] == pytest.approx(sig(xs), abs=1e-12)
    r = level_intersections(C, cells, one, np.array([2]), np.array([cH]), np.array([1]), np.array([cK]),
                            np.array([sig(0.2)]), np.array([sig(0.9)]), np.array([t(-1.0)]), np.array([t(1.0)]),
                            np.array([sig(0.5)]), np.array([t(0.0)]), 1e-13)
    assert np.isnan(r[0])


def test_interpolant_range_bounds_and_extremum_search():
    """Bernstein bounds of a cell's interpolant enclose its values on the cell; the extremum
    search finds an interior maximum (Newton from the grid's best point) and a corner
    minimum to rounding."""
    from hullprod_wb.brep.cubature.cell_interpolant import interpolant_extremum, interpolant_range, monomial_matrix
    deg = 9
    Minv = np.linalg.inv(monomial_matrix(deg))
    # K = 0.0009 - (x - 0.31)^2 - (y + 0.17)^2 + 0.05 x^3 y in local coordinates
    D = np.zeros((deg + 1, deg + 1))
    D[0, 0], D[1, 0], D[2, 0] = 0.0009 - 0.31 ** 2 - 0.17 ** 2, 0.62, -1.0
    D[0, 1], D[0, 2], D[3, 1] = -0.34, -1.0, 0.05
    C = np.zeros((1, 3, deg + 1, deg + 1))
    C[0, 1] = Minv.T @ D @ Minv
    K = lambda x, y: 0.0009 - (x - 0.31) ** 2 - (y + 0.17) ** 2 + 0.05 * x ** 3 * y
    g = np.linspace(-1, 1, 801)
    V = K(g[:, None], g[None, :])
    one = np.zeros(1, int)
    lo, hi = interpolant_range(C, one, 1)
    assert lo[0] <= V.min() + 1e-15 and hi[0] >= V.max() - 1e-15
    from scipy.optimize import minimize
    best = minimize(lambda p: -K(p[0], p[1]), [0.3, -0.2], tol=1e-14).x
    val, x, y = interpolant_extremum(C, one, 1, 1.0)
    assert val[0] == pytest.approx(K(*best), abs=1e-14)
    assert x[0] == pytest.approx(best[0], abs=1e-7) and y[0] == pytest.approx(best[1], abs=1e-7)
    val, x, y = interpolant_extremum(C, one, 1, -1.0)
    assert abs(x[0]) == 1.0 and abs(y[0]) == 1.0
    # the interpolant at that corner (P_k(+-1) = (+-1)^k), which is K there up to the rounding
    # of the inverse above
    k = np.arange(deg + 1)
    corner = x[0] ** k @ C[0, 1] @ y[0] ** k
    assert -val[0] == pytest.approx(corner, abs=1e-14)
    assert corner == pytest.approx(V.min(), abs=1e-12)


@needs_freecad
def test_grid_evaluated_cells_give_the_pointwise_values(fc):
    """A trimmed B-spline face has cells between constant bounds, evaluated as tensor grids
    (FaceField.grid), and cells along the trim curve, point by point: the cubature and the
    fixed area rule give the values of the same field evaluated point by point everywhere."""
    from hullprod_wb.brep.geometry.face_field import FaceField
    from hullprod_wb.brep.cubature.patches import Patches
    from hullprod_wb.brep.cubature import patch_area, tensor_cells
    Part, V = fc.Part, fc.V
    poles = [[V(3 * i, 2 * j, 0.3 * math.sin(i + 2 * j)) for j in range(5)] for i in range(5)]
    s = Part.BSplineSurface()
    s.buildFromPolesMultsKnots(poles, [4, 1, 4], [4, 1, 4], [0, 0.4, 1], [0, 0.6, 1], False, False, 3, 3)
    face = s.toShape().cut(Part.makeCylinder(1.5, 10, V(4.2, 3.1, -5))).Faces[0]
    d = TrimmedDomain.from_face(face)
    ff = FaceField(face)
    ub, vb = ff.evaluator.continuity_breaks()
    patches = Patches.of(d, ub, vb)
    tensor = tensor_cells(patches, np.arange(patches.size))
    assert tensor.any() and not tensor.all()

    class Pointwise:  # the same field without grid()
        def __call__(self, u, v):
            return ff(u, v)

    a = integrate(d, ff, 0.05, 0.02, u_breaks=ub, v_breaks=vb)
    b = integrate(d, Pointwise(), 0.05, 0.02, u_breaks=ub, v_breaks=vb)
    for q in QUANTITIES:
        assert a.values[q] == pytest.approx(b.values[q], rel=1e-9, abs=1e-12 * a.values["A"])
    grid_area = patch_area(d, ff.area_element, 8, ub, vb, ff.area_element_grid)
    point_area = patch_area(d, ff.area_element, 8, ub, vb)
    assert grid_area[0] == pytest.approx(point_area[0], rel=1e-13)
    assert grid_area[0] == pytest.approx(a.values["A"], rel=1e-9)
