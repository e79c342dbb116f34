"""The automatic reference length (core.reference_length): the principal-axis span from the
exact area moments of a triangulation, the same however plane regions are cut into
triangles, and on BRep files of one shape the same in every format."""
import numpy as np
import pytest

from conftest import needs_freecad, shared_hull
from hullprod_wb.core.errors import InputError
from hullprod_wb.core.reference_length import principal_axis_span, resolve_reference_length


def _rotation(seed):
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return q


def box_surface(lx, ly, lz, flip):
    """The six faces of an lx x ly x lz box, each cut into two triangles along the diagonal
    flip[i] picks (8 corners, 12 triangles)."""
    P = np.array([(x, y, z) for x in (0, lx) for y in (0, ly) for z in (0, lz)], float)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    T = []
    for (a, b, c, d), f in zip(quads, flip):
        T += [(a, b, c), (a, c, d)] if f else [(a, b, d), (b, c, d)]
    return P, np.array(T)


def _node_weighted_span(P, T):
    """The span from node-area-weighted points (what the exact moments replace)."""
    area = 0.5 * np.linalg.norm(np.cross(P[T[:, 1]] - P[T[:, 0]], P[T[:, 2]] - P[T[:, 0]]), axis=1)
    w = np.bincount(T.ravel(), weights=np.repeat(area / 3, 3), minlength=len(P))
    X = P - (w[:, None] * P).sum(0) / w.sum()
    axis = np.linalg.eigh((w[:, None] * X).T @ X)[1][:, -1]
    return np.ptp(X @ axis)


@pytest.mark.parametrize("seed", range(4))
def test_a_box_spans_its_length_however_its_faces_are_cut(seed):
    rng = np.random.default_rng(seed)
    P, T = box_surface(100.0, 40.0, 20.0, rng.integers(0, 2, 6))
    R = _rotation(seed)
    Q = P @ R.T + rng.normal(size=3) * 1e3
    assert principal_axis_span(Q, T) == pytest.approx(100.0, rel=1e-12)
    # the node-weighted points tilt the axis towards the heavier diagonals
    assert abs(_node_weighted_span(Q, T) - 100.0) > 1e-3


def test_subdivision_leaves_the_span_unchanged():
    """Splitting every triangle in four at its edge midpoints keeps the area measure of a
    polyhedral surface, so the axis and the span stay the same."""
    P, T = box_surface(70.0, 50.0, 30.0, [1, 0, 0, 1, 1, 0])
    P = P @ _rotation(7).T
    M = {}
    V = list(map(tuple, P))

    def mid(i, j):
        key = (min(i, j), max(i, j))
        if key not in M:
            M[key] = len(V)
            V.append(tuple(0.5 * (P[i] + P[j])))
        return M[key]
    T4 = []
    for a, b, c in T:
        ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
        T4 += [(a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)]
    assert principal_axis_span(np.array(V), np.array(T4)) == pytest.approx(principal_axis_span(P, T), rel=1e-12)
    assert principal_axis_span(P, T) == pytest.approx(70.0, rel=1e-12)


def test_given_areas_give_the_same_span():
    P, T = box_surface(9.0, 4.0, 1.0, [0, 1, 0, 1, 0, 1])
    area = 0.5 * np.linalg.norm(np.cross(P[T[:, 1]] - P[T[:, 0]], P[T[:, 2]] - P[T[:, 0]]), axis=1)
    node = np.bincount(T.ravel(), weights=np.repeat(area / 3, 3), minlength=len(P))
    assert principal_axis_span(P, T, node, area) == pytest.approx(principal_axis_span(P, T), rel=1e-14)


def test_points_that_are_not_finite_are_left_out():
    P, T = box_surface(10.0, 3.0, 2.0, [0] * 6)
    Pn = np.vstack([P, [np.nan, 0, 0]])
    Tn = np.vstack([T, [0, 1, len(P)]])
    assert principal_axis_span(Pn, Tn) == pytest.approx(10.0, rel=1e-12)
    with pytest.raises(InputError):
        principal_axis_span(np.array([[0.0, 0, 0], [np.nan, 0, 0]]), np.array([[0, 1, 1]]))


def test_no_area_falls_back_to_the_points():
    P = np.array([[0.0, 0, 0], [5.0, 0, 0], [2.0, 0, 0]])
    assert principal_axis_span(P, np.array([[0, 1, 2]])) == pytest.approx(5.0)
    rl = resolve_reference_length(P, np.array([[0, 1, 2]]), explicit=100.0)
    assert rl.mode == "explicit" and "check the units" in rl.warning


def test_the_automatic_length_is_stated_to_six_digits_and_stays_under_small_edits():
    P = np.array([[0.0, 0, 0], [123.4567891, 0, 0], [0.0, 2.0, 0], [123.4567891, 2.0, 0]])
    T = np.array([[0, 1, 2], [1, 3, 2]])
    rl = resolve_reference_length(P, T)
    assert principal_axis_span(P, T) == pytest.approx(123.4567891, rel=1e-12)
    assert rl.value == rl.automatic_value == 123.457 and "6 significant digits" in rl.method
    Q = P.copy()
    Q[1, 1] += 1e-6  # a corner moved: the span changes in its tenth digit, the stated length not
    assert principal_axis_span(Q, T) != principal_axis_span(P, T)
    assert resolve_reference_length(Q, T).value == rl.value
    assert resolve_reference_length(P, T, explicit=123.4567891).value == 123.4567891  # a given L_ref as given


@needs_freecad
def test_a_filleted_box_has_one_reference_length_in_every_format(tmp_path):
    """The same shape written as STEP, IGES and BRep: its automatic L_ref is its length in
    each (the tessellations differ between the formats' faces)."""
    from hullprod_wb import assess
    from hullprod_wb.freecad_env import import_freecad
    import_freecad()
    import Part
    box = Part.makeBox(100, 40, 20)
    shape = box.makeFillet(5, box.Edges)
    lrefs = {}
    for ext, write in (("step", shape.exportStep), ("iges", shape.exportIges), ("brep", shape.exportBrep)):
        path = str(tmp_path / ("box." + ext))
        write(path)
        lrefs[ext] = assess(path, with_fields=False, order=3, rtol=1e-2).reference_length.value
    assert lrefs == pytest.approx({"step": 100.0, "iges": 100.0, "brep": 100.0}, rel=1e-6)


@needs_freecad
def test_a_hull_with_plane_faces_spans_its_length():
    """The catamaran demi-hull (deck and transom are planes cut into a few long triangles):
    its automatic L_ref, by the backend's method, is its bounding-box length to 1e-3."""
    from hullprod_wb.app.worker import brep_lref
    from hullprod_wb.freecad_env import import_freecad
    import_freecad()
    import Part
    path = shared_hull("brep/catamaran_demihull.step")
    chosen, whole = brep_lref(path, None)
    assert chosen == whole == pytest.approx(Part.read(path).BoundBox.XLength, rel=1e-3)
