"""Verification studies: same-face recovery (eq:sameface_error), mesh-resolution ladder
(eq:class_l1), representation comparison and threshold study."""
import json
import math

import numpy as np
import pytest

from conftest import needs_freecad, shared_hull

pytestmark = needs_freecad


@pytest.fixture(scope="module")
def shapes():
    from hullprod_wb.examples import analytic_shapes
    from hullprod_wb.examples.builtin import half_wigley_shape
    return {"saddle": analytic_shapes.saddle_face(), "torus": analytic_shapes.torus_shape(),
            "half-wigley": half_wigley_shape()}


# ------------------------------------------------------------------------------------------
# building blocks


def test_grid_patterns_and_orientation():
    from hullprod_wb.studies.sameface import grid_parameters, grid_triangles, triangle_areas
    n = 6
    c, a = grid_triangles(n, "consistent"), grid_triangles(n, "alternating")
    assert c.shape == a.shape == (2 * n * n, 3)
    assert not np.array_equal(np.sort(c, axis=1), np.sort(a, axis=1))
    u, v = grid_parameters((0.0, 1.0, 0.0, 2.0), n)
    V = np.column_stack([u, v, np.zeros_like(u)])
    for T in (c, a):
        nz = np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])[:, 2]
        assert np.all(nz > 0)  # counter-clockwise in (u, v): normal along S_u x S_v
        assert triangle_areas(V, T).sum() == pytest.approx(2.0, rel=1e-14)
    flipped = grid_triangles(n, "consistent", flip=True)
    nz = np.cross(V[flipped[:, 1]] - V[flipped[:, 0]], V[flipped[:, 2]] - V[flipped[:, 0]])[:, 2]
    assert np.all(nz < 0)


def test_two_ring_interior_of_a_grid():
    from hullprod_wb.studies.sameface import grid_triangles, strict_interior
    n = 12
    keep = strict_interior(grid_triangles(n, "alternating"), (n + 1) ** 2).reshape(n + 1, n + 1)
    expect = np.zeros((n + 1, n + 1), dtype=bool)
    expect[3:n - 2, 3:n - 2] = True  # boundary ring 0 and rings 1, 2 removed
    assert np.array_equal(keep, expect)


def test_mass_matrix_and_error_norm():
    from hullprod_wb.studies.sameface import (grid_parameters, grid_triangles, h_sign_alignment,
                                              p1_mass_matrix, relative_l2_error)
    u, v = grid_parameters((0.0, 2.0, 0.0, 1.0), 8)
    V = np.column_stack([u, v, 0.3 * u * v])
    T = grid_triangles(8, "alternating")
    M = p1_mass_matrix(V, T)
    ones = np.ones(len(V))
    A = np.sqrt(1 + (0.3 * v) ** 2 + (0.3 * u) ** 2)  # only for scale
    assert float(ones @ (M @ ones)) == pytest.approx(float(M.sum()), rel=1e-14)
    assert np.allclose((M - M.T).toarray(), 0.0)
    assert float(ones @ (M @ ones)) > 2.0 and A.max() < 2  # area of the graph exceeds the flat 2
    x = np.sin(u) + v
    mask = np.ones(len(V), dtype=bool)
    assert relative_l2_error(x, x, M, mask) == 0.0
    assert relative_l2_error(1.1 * x, x, M, mask) == pytest.approx(0.1, rel=1e-12)
    assert relative_l2_error(x, np.zeros_like(x), M, mask) is None
    assert h_sign_alignment(-x, x, M, mask) == -1 and h_sign_alignment(x, x, M, mask) == 1
    # values outside the mask do not count
    y = np.where(u > 1.0, 1e9, x)
    assert relative_l2_error(y, x, M, u <= 1.0) == 0.0


def test_largest_rectangle():
    from hullprod_wb.studies.sameface import largest_rectangle
    g = np.zeros((10, 12), dtype=bool)
    g[2:7, 3:11] = True
    g[0:10, 0:2] = True  # 10 x 2 = 20 < 5 x 8 = 40
    assert largest_rectangle(g) == (2, 6, 3, 10)
    assert largest_rectangle(np.zeros((3, 3), bool)) is None


def test_grid_lines_place_creases_on_grid_lines():
    from hullprod_wb.core.errors import InputError
    from hullprod_wb.studies.sameface import grid_lines, grid_parameters, panel_split
    lines, idx = grid_lines(0.5, 9.5, 48, [2.5, 3.5, 9.5, 11.0])  # only creases inside (lo, hi) count
    assert lines.shape == (49,) and np.all(np.diff(lines) > 0)
    assert lines[0] == 0.5 and lines[-1] == 9.5
    assert list(lines[idx]) == [2.5, 3.5]  # exactly on grid lines
    # 48 panels over pieces of length 2, 1, 6 (ideal 10.67, 5.33, 32): largest remainder 11, 5, 32
    assert list(np.diff(np.r_[0, idx, 48])) == [11, 5, 32]
    assert list(panel_split([1.0, 1.0, 1.0], 3)) == [1, 1, 1]
    assert list(panel_split([0.01, 1.0], 12)) == [1, 11]  # every piece keeps at least one panel
    with pytest.raises(InputError):
        panel_split(np.ones(13), 12)
    uniform, none = grid_lines(0.0, 1.0, 12, [])
    assert np.array_equal(uniform, np.linspace(0.0, 1.0, 13)) and none.size == 0
    u, v = grid_parameters((0.0, 3.0, 0.0, 1.0), 12, ([1.0], []))
    assert np.isclose(u.reshape(13, 13)[:, 0], 1.0).sum() == 1


def test_two_ring_interior_with_crease_rows():
    from hullprod_wb.studies.sameface import break_rings, grid_triangles, strict_interior
    n = 16
    seeds = np.zeros((n + 1, n + 1), dtype=bool)
    seeds[8, :] = True  # a crease row, treated like the boundary
    keep = strict_interior(grid_triangles(n, "consistent"), (n + 1) ** 2,
                           seeds=seeds.ravel()).reshape(n + 1, n + 1)
    expect = np.zeros((n + 1, n + 1), dtype=bool)
    expect[3:6, 3:n - 2] = True   # rows 6..10 are within two edges of row 8
    expect[11:n - 2, 3:n - 2] = True
    assert np.array_equal(keep, expect)
    # break rings by grid index: row i is flagged when the break lies in [u_{i-2}, u_{i+2}]
    lines = np.linspace(0.0, 1.0, n + 1)
    flag = break_rings(lines, lines, ([8.5 / n], [])).reshape(n + 1, n + 1)
    assert np.array_equal(np.flatnonzero(flag[:, 0]), [7, 8, 9, 10])  # |u_i - b| <= 2 h
    flag = break_rings(lines, lines, ([], [0.5])).reshape(n + 1, n + 1)
    assert np.array_equal(np.flatnonzero(flag[0]), [6, 7, 8, 9, 10])


# ------------------------------------------------------------------------------------------
# same-face study on exact BRep controls


@pytest.mark.parametrize("name", ["saddle", "torus", "half-wigley"])
def test_sameface_controls_converge(shapes, name):
    from hullprod_wb.studies import sameface_study
    doc = sameface_study(shapes[name])
    json.dumps(doc, allow_nan=False)
    (face,) = doc["faces"]
    assert face["face"] == 1 and not face["trimmed"]
    assert {(r["panels"], r["pattern"]) for r in face["levels"]} == {
        (n, p) for n in (12, 24, 48) for p in ("consistent", "alternating")}
    for pattern in ("consistent", "alternating"):
        recs = sorted((r for r in face["levels"] if r["pattern"] == pattern), key=lambda r: r["panels"])
        for q in ("eps_H", "eps_K"):
            e = [r[q] for r in recs]
            # smooth surfaces, uniform grids: the estimator is consistent, so every halving of
            # the spacing must lower the error
            assert e[0] > e[1] > e[2], (name, pattern, q, e)
            # second-order recovery gives 48/12 ratios near 1/16 (measured 0.035-0.14); 1/4
            # (first order) is the bound a regression of the estimator would cross
            assert e[2] / e[0] < 0.25, (name, pattern, q, e)
            # 48 x 48: measured at most 1.5 % (torus K, the largest curvature variation per
            # panel); 2 % leaves room for rounding, far below the hull errors of the paper
            assert e[2] < 0.02, (name, pattern, q, e)
        # no knot lines below C2 on these exact patches: both masks agree
        assert all(r["eps_K_smooth"] == r["eps_K"] for r in recs)
    assert face["creases"] == {"u": [], "v": []}
    assert all(r["H_sign"] in (1, -1) for r in face["levels"])


def test_sameface_inset_and_bad_input(shapes):
    from hullprod_wb.core.errors import InputError
    from hullprod_wb.studies import sameface_study
    doc = sameface_study(shapes["half-wigley"], levels=(12,), patterns=("consistent",), inset=0.1)
    u0, u1, v0, v1 = doc["faces"][0]["rect"]
    assert (u0, u1, v0, v1) == pytest.approx((0.1, 0.9, 0.1, 0.9))
    with pytest.raises(InputError):
        sameface_study(shapes["half-wigley"], levels=(4,))
    with pytest.raises(InputError):
        sameface_study(shapes["half-wigley"], patterns=("random",))
    with pytest.raises(InputError):
        sameface_study(shapes["half-wigley"], inset=0.6)


def test_sameface_trimmed_face_rectangle_inside_domain():
    import Part
    from hullprod_wb.brep.geometry.trimmed_domain import TrimmedDomain
    from hullprod_wb.studies.sameface import grid_parameters, inset_rectangle
    face = Part.Face(Part.Wire(Part.makeCircle(1.0)))  # a unit disc: a trimmed plane
    region = inset_rectangle(face)
    assert region["trimmed"]
    # the largest inscribed square of the unit disc has area 2; raster (1/96 cells, one cell
    # dropped per side) and the 5 % inset leave (0.9 (sqrt(2) - 3/48))^2 ~ 1.48 at least
    b = region["base_rect"]
    assert (b[1] - b[0]) * (b[3] - b[2]) > 1.8
    r = region["rect"]
    assert (r[1] - r[0]) * (r[3] - r[2]) > 1.45
    dom = TrimmedDomain.from_face(face)
    u, v = grid_parameters(region["rect"], 48)
    idx, lo, hi = dom.v_intervals(u)
    inside = np.zeros(u.size, bool)
    inside[idx[(v[idx] >= lo) & (v[idx] <= hi)]] = True
    assert inside.all()


def creased_face(slope=-0.2):
    """Cubic B-spline graph z = g(x) + h(y) with a crease (C0 triple knot) at u = x = 1.

    g = 0.3 x^2 on [0, 1] and 0.3 + slope (x - 1) + 0.3 (x - 1)^2 on [1, 3] (the tangent
    turns by atan 0.6 - atan(slope), 42 degrees for slope -0.2), h = 0.25 y^2 on [0, 1].
    Poles from the Bernstein coefficients of t and t^2 in degree 3: (0, 1/3, 2/3, 1), (0, 0, 1/3, 1);
    x(u) = u, y(v) = v.
    """
    from hullprod_wb.freecad_env import import_freecad
    FreeCAD = import_freecad()
    import Part
    lin, sq = np.array([0.0, 1 / 3, 2 / 3, 1.0]), np.array([0.0, 0.0, 1 / 3, 1.0])
    g = np.r_[0.3 * sq, (0.3 + slope * 2 * lin + 0.3 * 4 * sq)[1:]]  # piece 2: t = (x - 1)/2
    x = np.r_[lin, 1 + 2 * lin[1:]]
    poles = [[FreeCAD.Vector(x[i], lin[j], g[i] + 0.25 * sq[j]) for j in range(4)] for i in range(7)]
    s = Part.BSplineSurface()
    s.buildFromPolesMultsKnots(poles, [4, 3, 4], [4, 4], [0.0, 1.0, 3.0], [0.0, 1.0], False, False, 3, 3)
    return s.toShape()


def test_sameface_crease_on_grid_lines():
    """A C0 knot line (a crease) inside the face: on a grid line and masked like the boundary,
    the recovery converges as on the smooth controls; straddled by triangles it diverges."""
    from hullprod_wb.studies import sameface_study
    face = creased_face()
    aligned = sameface_study(face)["faces"][0]
    assert aligned["creases"] == {"u": [1.0], "v": []}
    uniform = sameface_study(face, align_creases=False)["faces"][0]
    assert uniform["creases"] == {"u": [], "v": []}
    for pattern in ("consistent", "alternating"):
        a = {r["panels"]: r for r in aligned["levels"] if r["pattern"] == pattern}
        u = {r["panels"]: r for r in uniform["levels"] if r["pattern"] == pattern}
        for q in ("eps_H", "eps_K"):
            # each piece is a smooth cubic patch: second order as on the controls (measured
            # 48/12 ratios 0.068-0.072, 48 x 48 errors 0.05 % H, 0.10 % K)
            assert a[12][q] > a[24][q] > a[48][q], (pattern, q)
            assert a[48][q] / a[12][q] < 0.25 and a[48][q] < 0.02, (pattern, q)
            # the uniform grid's crease lies inside a panel row (u = 1 at 15.1 panels of 48): the
            # mesh curvature there grows like angle / h, so the error grows with refinement
            # (measured H 68 -> 110 %, K 126 -> 210 %)
            assert u[48][q] > u[12][q] > 0.5, (pattern, q)
            # the 'smooth' diagnostic of the uniform grid (no two-ring across the knot line)
            # sees the same smooth pieces: the same order of error as the aligned grid
            assert u[48][q + "_smooth"] < 2 * a[48][q], (pattern, q)


def _abs_K_shares_midpoint(path, m=200):
    """{face: share of the integral of |K| dA}, midpoint rule on m x m parameter cells of each
    (untrimmed) face; an estimate independent of the BRep backend's quadrature."""
    from hullprod_wb.brep.geometry.differential import surface_differentials
    from hullprod_wb.brep.reading.loading import load_brep
    from hullprod_wb.brep.geometry.surface_eval import SurfaceEvaluator
    out = {}
    for number, face in load_brep(path).faces:
        ev = SurfaceEvaluator.for_face(face)
        u0, u1, v0, v1 = ev.parameter_range
        du, dv = (u1 - u0) / m, (v1 - v0) / m
        uu, vv = np.meshgrid(u0 + du * (np.arange(m) + 0.5), v0 + dv * (np.arange(m) + 0.5), indexing="ij")
        d = surface_differentials(ev.derivatives(uu.ravel(), vv.ravel()), ev.orientation_sign)
        ok = d.regular & np.isfinite(d.K)
        out[number] = float(np.sum(np.abs(d.K[ok]) * d.J[ok])) * du * dv
    total = sum(out.values())
    return {k: v / total for k, v in out.items()}


#: Paper, Table tab:same_face_verification, 48 x 48 over its four hulls: eps_H <= 4.336 %,
#: eps_K <= 8.211 %; the acceptance criterion rounds these to 4.4 % and 8.3 %.
PAPER_MAX_EPS_H, PAPER_MAX_EPS_K = 0.044, 0.083


def _by_level(face, pattern):
    return {r["panels"]: r for r in face["levels"] if r["pattern"] == pattern}


def test_sameface_real_hull():
    """DTMB 5415 (public Overture IGES), the paper's Table tab:same_face_verification hull, on
    the paper's mask with the crease rows of faces 1 and 2 on grid lines (module docstring)."""
    from hullprod_wb.studies import sameface_study
    path = shared_hull("brep/dtmb5415_half_overture.igs")
    doc = sameface_study(path, levels=(12, 48))
    assert [f["face"] for f in doc["faces"]] == [1, 2, 3]
    assert [f["creases"]["u"] for f in doc["faces"]] == [[2.5, 3.5], [7.5], []]
    # every face, both patterns, H and K: the 48 x 48 error below the 12 x 12 error
    for f in doc["faces"]:
        for pattern in ("consistent", "alternating"):
            by = _by_level(f, pattern)
            for q in ("eps_H", "eps_K"):
                assert by[48][q] < by[12][q], (f["face"], pattern, q)
    # face 1 (bow and sonar dome) carries the largest share of the integral of |K|: 0.901 by the
    # BRep backend's per-face records, 0.906 by this midpoint estimate (200 x 200 cells)
    shares = _abs_K_shares_midpoint(path)
    assert max(shares, key=shares.get) == 1 and shares[1] > 0.85
    # face 2 (main hull face, 80 % of the area): within the paper's range at 48 x 48
    # (measured H 1.56 / 1.58 %, K 4.24 / 4.25 %)
    for pattern in ("consistent", "alternating"):
        r = _by_level(doc["faces"][1], pattern)[48]
        assert r["eps_H"] <= PAPER_MAX_EPS_H and r["eps_K"] <= PAPER_MAX_EPS_K
    # face 1 at 48 x 48 (measured H 5.53 / 5.31 %, K 8.73 / 8.94 %) is above that range; its
    # error is resolution-limited (dome radii down to half the grid spacing), the study's
    # diagnosis names it so, and one more halving brings it inside the range
    # (measured 96 x 96: H 1.94 / 1.87 %, K 5.40 / 5.72 %)
    assert "resolution" in doc["faces"][0]["diagnosis"]["causes"]
    fine = sameface_study(path, faces=[1], levels=(96,))["faces"][0]
    for r in fine["levels"]:
        assert r["eps_H"] <= PAPER_MAX_EPS_H and r["eps_K"] <= PAPER_MAX_EPS_K, r["pattern"]


def test_sameface_headline_face_within_paper_range():
    """The headline figure of a hull is its face of largest area: on DTMB 5415 the main hull
    face (face 2, 80 % of the area), whose 48 x 48 errors lie within the paper's published
    range on both patterns; the face carrying the largest share of the integral of |K| (the
    bow with the sonar dome) is named beside it with its own figures."""
    from hullprod_wb.studies import sameface_study
    path = shared_hull("brep/dtmb5415_half_overture.igs")
    doc = sameface_study(path, levels=(12, 48))
    for f in doc["faces"]:
        for pattern in ("consistent", "alternating"):
            by = _by_level(f, pattern)
            assert by[48]["eps_H"] < by[12]["eps_H"] and by[48]["eps_K"] < by[12]["eps_K"]
    head = doc["headline_face"]
    assert head["face"] == max(doc["faces"], key=lambda f: f["area"])["face"] == 2
    assert head["rule"] == "largest area of the faces" and head["passed_over"] == []
    assert head["panels"] == 48
    for pattern in ("consistent", "alternating"):
        assert head["eps_H"][pattern] <= PAPER_MAX_EPS_H and head["eps_K"][pattern] <= PAPER_MAX_EPS_K, pattern
        assert head["eps_K"][pattern] == _by_level(doc["faces"][1], pattern)[48]["eps_K"]
    # the study's own |K| shares (midpoint rule on the trimmed-domain raster) rank the faces as
    # the independent 200 x 200 estimate does
    shares = _abs_K_shares_midpoint(path)
    top = doc["largest_K_face"]
    assert top["face"] == max(shares, key=shares.get) == 1
    assert top["abs_K_share"] == pytest.approx(shares[1], abs=0.02)
    assert sum(f["abs_K_share"] for f in doc["faces"]) == pytest.approx(1.0, rel=1e-12)
    # --faces overrides the selection: the headline is the largest of the selected faces
    one = sameface_study(path, faces=[1, 3], levels=(12,), patterns=("consistent",))
    assert one["headline_face"]["face"] == 1 and one["headline_face"]["rule"] == "largest area of the selected faces"


def test_sameface_single_face_hull_c1_knot_lines():
    """Wigley (WaveBEM IGES, one face, so it carries all of the integral of |K|): two C1 knot
    lines (H and K jump, the tangent plane does not), no crease."""
    from hullprod_wb.studies import sameface_study
    path = shared_hull("brep/wigley_half_wavebem.iges")
    doc = sameface_study(path, levels=(12, 48))
    (face,) = doc["faces"]
    assert face["creases"] == {"u": [], "v": []}
    assert face["levels"][0]["c2_breaks"]["v"] == pytest.approx([0.4344, 0.6784], abs=1e-4)
    for pattern in ("consistent", "alternating"):
        by = _by_level(face, pattern)
        for q in ("eps_H", "eps_K"):
            assert by[48][q] < by[12][q]
        # the paper's mask includes the C1 lines (measured 48 x 48: H 8.95 %, K 11.1 %, above the
        # paper's range); the 'smooth' diagnostic without their two-rings is a resolved smooth
        # surface (measured H 0.20 / 0.21 %, K 0.34 / 0.36 %): the C1 lines carry the error
        assert by[48]["eps_H_smooth"] < 0.005 and by[48]["eps_K_smooth"] < 0.005
        assert by[48]["eps_H_smooth"] < 0.1 * by[48]["eps_H"]
        assert by[48]["eps_K_smooth"] < 0.1 * by[48]["eps_K"]


def nulls_without_reason(doc, path="doc"):
    """[path] of every null value in a study document whose record (the dict holding it) has
    no non-empty reason for it in its own ``reasons``; nulls inside lists count as unexplained."""
    out = []
    if isinstance(doc, dict):
        reasons = doc.get("reasons") or {}
        for k, v in doc.items():
            if v is None and not (isinstance(reasons.get(k), str) and reasons[k].strip()):
                out.append("%s.%s" % (path, k))
            elif k != "reasons":
                out += nulls_without_reason(v, "%s.%s" % (path, k))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            out += ["%s[%d]" % (path, i)] if v is None else nulls_without_reason(v, "%s[%d]" % (path, i))
    return out


def many_creases_face():
    """Degree-1 by degree-2 B-spline graph z = zigzag(x) + 0.25 y^2 on [0, 8] x [0, 1]: seven
    C0 knot lines inside the inset region (eight pieces), K = 0 on every piece, H != 0."""
    from hullprod_wb.freecad_env import import_freecad
    FreeCAD = import_freecad()
    import Part
    poles = [[FreeCAD.Vector(i, 0.5 * j, 0.3 * (i % 2) + 0.25 * (0.0, 0.0, 1.0)[j]) for j in range(3)]
             for i in range(9)]
    s = Part.BSplineSurface()
    s.buildFromPolesMultsKnots(poles, [2] + [1] * 7 + [2], [3, 3], [float(k) for k in range(9)], [0.0, 1.0],
                               False, False, 1, 2)
    return s.toShape()


def test_sameface_every_null_has_its_reason():
    """A level with fewer panels than crease-cut pieces, a level whose every vertex is masked
    and a reference that is identically zero: each null says why, in the record and in the
    plain-text table."""
    from hullprod_wb.studies import sameface_study
    from hullprod_wb.studies.cli import study_summary
    doc = sameface_study(many_creases_face(), levels=(6, 12, 48))
    json.dumps(doc, allow_nan=False)
    assert nulls_without_reason(doc) == []
    (face,) = doc["faces"]
    assert len(face["creases"]["u"]) == 7
    by = _by_level(face, "consistent")
    assert by[6]["unavailable"] and "crease lines" in by[6]["reasons"]["eps_H"]
    assert by[12]["n_retained"] == 0 and by[12]["reasons"]["eps_H"].startswith("every vertex masked")
    assert by[48]["n_retained"] > 0 and by[48]["eps_H"] is not None
    # K = 0 on every piece: the BRep K is zero to rounding, so no relative error is quoted
    assert by[48]["eps_K"] is None and "zero" in by[48]["reasons"]["eps_K"]
    import html
    from hullprod_wb.studies import report_html
    text, page = study_summary(doc), report_html(None, doc)
    for why in (by[6]["reasons"]["eps_H"], by[12]["reasons"]["eps_H"], by[48]["reasons"]["eps_K"]):
        assert why in text and html.escape(why) in page
    # the headline is the only face; its K figure is null with the same reason
    assert doc["headline_face"]["face"] == 1
    assert doc["headline_face"]["eps_K"]["reasons"]["consistent"] == by[48]["reasons"]["eps_K"]
    # at 12 panels alone nothing is retained: the diagnosis says so, and there is no headline
    coarse = sameface_study(many_creases_face(), levels=(12,))
    assert nulls_without_reason(coarse) == []
    assert coarse["faces"][0]["diagnosis"]["causes"] == ["every vertex masked"]
    assert coarse["headline_face"]["face"] is None and coarse["headline_face"]["passed_over"][0]["face"] == 1


#: Shared hulls whose every same-face record is walked, with the levels used (the coarsest
#: and finest default levels; the 125-face KCS at one level pair keeps the test near 20 s).
SHARED_STUDIES = [("brep/dtmb5415_half_overture.igs", (12, 24, 48)), ("brep/kvlcc2_half_overture.igs", (12, 24, 48)),
                  ("brep/kcs_full_closed_ohp.iges", (12, 48)), ("brep/wigley_full_freecadship.brep", (12, 48)),
                  ("brep/catamaran_demihull.step", (12, 48)), ("brep/series60_half_wavebem.iges", (12, 24, 48))]


@pytest.mark.parametrize("hull,levels", SHARED_STUDIES, ids=[h.split("/")[1] for h, _ in SHARED_STUDIES])
def test_sameface_shared_hulls_no_null_without_reason(hull, levels):
    """Every record of the shared hulls' same-face studies: no null without its reason, and a
    large finest-level error (above the paper's range) always has a named cause."""
    from hullprod_wb.studies import sameface_study
    doc = sameface_study(shared_hull(hull), levels=levels)
    json.dumps(doc, allow_nan=False)
    assert nulls_without_reason(doc) == []
    assert doc["headline_face"]["face"] is not None
    for f in doc["faces"]:
        if f.get("skipped"):
            continue
        fine = [r for r in f["levels"] if r["panels"] == max(levels) and not r.get("unavailable")]
        large = any((r["eps_H"] or 0) > PAPER_MAX_EPS_H or (r["eps_K"] or 0) > PAPER_MAX_EPS_K for r in fine)
        if large:
            assert f["diagnosis"]["causes"], (hull, f["face"], f["diagnosis"])


def test_sameface_diagnosis_names_knot_lines_and_aspect():
    """Wigley (WaveBEM, two C1 knot lines): the diagnosis finds the error at the knot lines;
    a saddle stretched 30 : 1 has its panels' aspect measured and named."""
    from hullprod_wb.examples import analytic_shapes
    from hullprod_wb.studies import sameface_study
    doc = sameface_study(shared_hull("brep/wigley_half_wavebem.iges"), levels=(12, 48))
    assert "knot lines" in doc["faces"][0]["diagnosis"]["causes"]
    assert doc["faces"][0]["diagnosis"]["evidence"]["c1_lines"] == 2
    import FreeCAD
    shape = analytic_shapes.saddle_face()
    m = FreeCAD.Matrix()
    m.scale(30.0, 1.0, 1.0)
    stretched = shape.transformGeometry(m)
    f = sameface_study(stretched, levels=(12, 24))["faces"][0]
    asp = _by_level(f, "consistent")[24]["panel_aspect"]
    assert asp["median"] > 20 and "panel aspect" in f["diagnosis"]["causes"]
    plain = sameface_study(shape, levels=(12, 24))["faces"][0]
    assert _by_level(plain, "consistent")[24]["panel_aspect"]["median"] < 2
    assert "panel aspect" not in plain["diagnosis"]["causes"]


# ------------------------------------------------------------------------------------------
# refinement, representation, thresholds


def test_class_l1_and_relative_change():
    from hullprod_wb.studies.refinement import class_l1, relative_change
    a = {"flat": 0.1, "single": 0.2, "elliptic": 0.3, "saddle": 0.4}
    b = {"flat": 0.0, "single": 0.2, "elliptic": 0.5, "saddle": 0.3}
    assert class_l1(a, a) == 0.0
    assert class_l1(a, b) == pytest.approx(0.4)
    assert class_l1(a, dict(b, flat=None)) is None
    assert relative_change(1.1, 1.0) == pytest.approx(0.1)
    assert relative_change(1.0, 0.0) is None


def test_refinement_identical_meshes_have_zero_change():
    from hullprod_wb.examples.analytic_meshes import half_wigley_mesh
    from hullprod_wb.studies import refinement_study
    m = half_wigley_mesh(32, 8)
    doc = refinement_study(meshes=[m, m], lref=1.0)
    json.dumps(doc, allow_nan=False)
    for r in doc["levels"]:
        assert r["d1"] == 0.0
        assert all(v == 0.0 for v in r["relative_change"].values())
    assert doc["successive"][0]["d1"] == 0.0


def test_refinement_wigley_tessellation_ladder():
    from hullprod_wb.examples.builtin import half_wigley_shape
    from hullprod_wb.studies import refinement_study
    doc = refinement_study(source=half_wigley_shape(), lref=1.0)
    levels = doc["levels"]
    coarse, medium, fine = levels
    assert [r["name"] for r in levels] == ["coarse", "medium", "fine"]
    assert coarse["n_triangles"] < medium["n_triangles"] < fine["n_triangles"]
    assert doc["settings"]["linear_deflection_over_lref"] == [0.0035, 0.00175, 0.000875]
    # what the study guarantees, whichever mesher made the ladder (how fast the values
    # settle depends on OpenCascade's version): every level against the finest, and each
    # level against the next, from the levels' own values
    d1 = lambda a, b: sum(abs(a["a_C"][c] - b["a_C"][c]) for c in b["a_C"])
    for r in levels:
        assert r["quality"]["counts"]["faces"] == r["n_triangles"]
        assert sum(r["a_C"].values()) == pytest.approx(1.0, abs=1e-12)
        assert r["I_D"] > 0.0 and math.isfinite(r["I_D"])
        assert r["d1"] == pytest.approx(d1(r, fine), rel=1e-12, abs=1e-15)
        for m in ("I_D", "I_D_plus", "I_D_minus"):
            assert r["relative_change"][m] == pytest.approx((r[m] - fine[m]) / abs(fine[m]), rel=1e-12, abs=1e-15)
    assert fine["d1"] == 0.0 and set(fine["relative_change"].values()) == {0.0}
    assert coarse["d1"] > 0.0 and medium["d1"] > 0.0  # three different meshes
    for step, lo, hi in zip(doc["successive"], levels[:-1], levels[1:]):
        assert (step["from"], step["to"]) == (lo["name"], hi["name"])
        assert step["d1"] == pytest.approx(d1(lo, hi), rel=1e-12, abs=1e-15)
        assert step["relative_change_I_D"] == pytest.approx((lo["I_D"] - hi["I_D"]) / abs(hi["I_D"]), rel=1e-12)


def test_refinement_bad_input():
    from hullprod_wb.core.errors import InputError
    from hullprod_wb.examples.builtin import half_wigley_shape
    from hullprod_wb.studies import refinement_study
    with pytest.raises(InputError):
        refinement_study()
    with pytest.raises(InputError):
        refinement_study(source=half_wigley_shape(), lref=1.0, linear=(0.01,), angular=(0.3, 0.2))


def test_threshold_study_on_mesh():
    from hullprod_wb.examples.analytic_meshes import torus_mesh
    from hullprod_wb.studies import threshold_study
    doc = threshold_study(torus_mesh(48), lref=8.0, tolerances=(1e-3, 1e-5, 1e-4))
    assert doc["tolerances"] == [1e-5, 1e-4, 1e-3]
    # I_D does not depend on the class tolerances: the vertex sums are identical
    assert doc["max_I_D_spread"] == 0.0
    dc = [r["double_curved"] for r in doc["rows"]]
    assert dc[0] >= dc[1] >= dc[2]  # a wider quasi-zero band can only take area from K != 0
    for r in doc["rows"]:
        assert sum(r["a_C"].values()) == pytest.approx(1.0, abs=1e-12)


def test_threshold_table_shows_each_value_status():
    """The report's and the command line's threshold tables carry each value's validity
    status; the report's heading is the one asked for."""
    from hullprod_wb.examples.analytic_meshes import torus_mesh
    from hullprod_wb.studies import report_html, threshold_study
    from hullprod_wb.studies.cli import study_summary
    doc = threshold_study(torus_mesh(48), lref=8.0, tolerances=(1e-4,))
    row = doc["rows"][0]
    page = report_html(None, doc, title="HullProd thresholds study: Torus")
    section = page.split("<h2>Threshold study</h2>", 1)[1]
    statuses = [row["status"][q] for q in ("I_D", "I_D_plus", "I_D_minus", "a_flat", "a_single", "a_elliptic",
                                           "a_saddle")]
    assert section.count('class="badge"') == 7
    assert [b.split(">", 1)[1].split("<", 1)[0] for b in section.split('class="badge"')[1:]] == statuses
    assert "<h1>HullProd thresholds study: Torus</h1>" in page
    assert study_summary(doc).splitlines()[2].endswith(" ".join(statuses))


def test_representation_wigley_brep_against_tessellation():
    from hullprod_wb.examples.builtin import WIGLEY_REFERENCE, half_wigley_shape
    from hullprod_wb.studies import representation_study
    # coarse quadrature keeps the test fast; the BRep I_D still lands within 1e-3 of the reference
    doc = representation_study(half_wigley_shape(), lref=1.0, brep_options={"order": 4, "max_depth": 2,
                                                                             "rtol": 1e-3})
    json.dumps(doc, allow_nan=False)
    brep, mesh = doc["rows"]
    assert brep["representation"] == "native BRep" and mesh["representation"] == "triangle mesh"
    assert brep["I_D"] == pytest.approx(WIGLEY_REFERENCE["I_D"], rel=1e-3)
    assert doc["delta_percent"]["I_D"] == pytest.approx(100 * (mesh["I_D"] / brep["I_D"] - 1), rel=1e-12)
    red = doc["class_redistribution"]
    assert sum(red.values()) == pytest.approx(0.0, abs=1e-9)
    assert doc["d1"] == pytest.approx(sum(abs(x) for x in red.values()), rel=1e-12)
    assert doc["mesh"]["kind"] == "tessellation" and doc["mesh"]["n_triangles"] > 0


# ------------------------------------------------------------------------------------------
# command line


def test_cli_sameface_json_contract(capsys, tmp_path):
    from hullprod_wb.cli import main
    from hullprod_wb.examples.builtin import half_wigley_shape
    step = str(tmp_path / "w.step")
    half_wigley_shape().exportStep(step)
    out = tmp_path / "out"
    assert main(["study", "sameface", step, "--faces", "1", "--json", "--quiet", "--out", str(out)]) == 0
    doc = json.loads(capsys.readouterr().out)
    (face,) = doc["faces"]
    assert face["face"] == 1
    assert {r["panels"] for r in face["levels"]} == {12, 24, 48}
    assert {r["pattern"] for r in face["levels"]} == {"consistent", "alternating"}
    assert all(0.0 < r["eps_H"] < 1.0 and 0.0 < r["eps_K"] < 1.0 for r in face["levels"])  # fractions
    assert (out / "study_sameface.json").is_file()
    assert doc["headline_face"]["face"] == doc["largest_K_face"]["face"] == 1
    assert doc["headline_face"]["rule"] == "largest area of the selected faces"
    assert nulls_without_reason(doc) == []
    assert main(["study", "sameface", step, "--levels", "3", "--quiet"]) == 2
