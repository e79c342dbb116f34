"""Isolated degenerate points inside a knot span (brep.geometry.degenerate_points), audited
like those on the knot grid (brep.validity.singular), against a closed form."""
import math

import numpy as np
import pytest

from conftest import needs_freecad

pytestmark = needs_freecad

from hullprod_wb import assess  # noqa: E402
from hullprod_wb.brep.geometry.degenerate_points import isolated_zeros  # noqa: E402
from hullprod_wb.brep.geometry.face_field import FaceField  # noqa: E402
from hullprod_wb.brep.geometry.trimmed_domain import TrimmedDomain  # noqa: E402
from hullprod_wb.brep.validity import singular  # noqa: E402
from hullprod_wb.examples.analytic_shapes import bezier_face  # noqa: E402

A, B = 0.37, 0.61  # the degenerate point, inside the single span [0, 1]^2


def pinched_face(a=A, b=B, k=0.0):
    """S(u, v) = (x, x y, y^2), x = u - a + k (v - b), y = v - b, on [0, 1]^2 (an exact Bezier
    patch of degree (1, 2)): N = S_u x S_v vanishes at (a, b) alone, where J = |N| grows like
    the distance and |K| = 4 y^2 / J^4 like its inverse square. The shear k turns [N_u N_v]
    from singular values of ratio 1/2 (k = 0) towards rank one: J, and with it |K| J, then
    peaks sharply along one ray from the point."""
    def S(u, v):
        x, y = np.broadcast_arrays(u - a + k * (v - b), v - b)
        return np.stack((x, x * y, y * y), -1)
    # the Bernstein coefficients from the values at (i / 1, j / 2): exact for degree (1, 2)
    from math import comb
    nodes_u, nodes_v = np.array([0.0, 1.0]), np.array([0.0, 0.5, 1.0])
    Bu = np.array([[comb(1, i) * x ** i * (1 - x) ** (1 - i) for i in range(2)] for x in nodes_u])
    Bv = np.array([[comb(2, j) * y ** j * (1 - y) ** (2 - j) for j in range(3)] for y in nodes_v])
    values = S(nodes_u[:, None], nodes_v[None, :])
    P = np.einsum("ai,bj,ijc->abc", np.linalg.inv(Bu), np.linalg.inv(Bv), values)
    return bezier_face(P)


def closed_form_abs_K(a=A, b=B, k=0.0):
    """int |K| dA = int_y (1 + y^2)^-1 [x / sqrt(4 y^2 (1 + y^2) + x^2)] dy, x from -a + k y to
    1 - a + k y (|K| J = 4 y^2 / J^3, J^2 = 4 y^2 (1 + y^2) + x^2 in (x, y), a shear of (u, v)
    of determinant one; the x integral in closed form)."""
    from scipy.integrate import quad

    def f(y):
        c = 4.0 * y * y * (1.0 + y * y)
        ends = ((1.0, 1.0 - a + k * y), (-1.0, -a + k * y))
        return sum(s * x / math.sqrt(c + x * x) for s, x in ends) / (1.0 + y * y)
    return quad(f, -b, 1.0 - b, points=[0.0], epsabs=0.0, epsrel=1e-13, limit=200)[0]


def test_a_strongly_sheared_pinch_point_keeps_its_error_within_the_estimate():
    """At shear 20 |K| J peaks along a ray so narrow that the quadtree around the pinch
    point's box does not reach rtol with the default budget; the error estimate must still
    cover the error against the closed form, and the status say how it was established."""
    face = pinched_face(k=20.0)
    exact = closed_form_abs_K(k=20.0)
    r = assess(face, lref=1.0, with_fields=False)
    v = r.validity["I_D"]
    assert abs(r.integrals.int_abs_K - exact) <= v.evidence["error_estimate"] * r.integrals.valid_area
    assert v.status.value == "VALID*"


def test_the_zero_inside_the_span_is_found_and_not_a_collapsed_side():
    ff = FaceField(pinched_face())
    (u, v), = isolated_zeros(ff.evaluator, [0.0, 1.0], [0.0, 1.0], 1e-8)
    assert abs(u - A) < 1e-12 and abs(v - B) < 1e-12
    deg = singular.find_degenerate(ff, TrimmedDomain.rectangle(0.0, 1.0, 0.0, 1.0), [], [])
    assert deg.points == [] and len(deg.interior) == 1
    assert np.allclose(deg.interior[0], (A, B), atol=1e-12, rtol=0)
    # a line of zeros (a collapsed side) has a rank-one Jacobian there and is not a point
    from hullprod_wb.examples.analytic_shapes import unit_sphere
    sphere = FaceField(unit_sphere().Faces[0])
    (u0, u1, v0, v1) = sphere.face.ParameterRange
    assert isolated_zeros(sphere.evaluator, [u0, u1], [v0, v1], 1e-8) == []


@pytest.mark.parametrize("shear", [0.0, 10.0])
def test_pinch_point_is_integrated_in_whitened_polar_coordinates_and_audited(monkeypatch, shear):
    face = pinched_face(k=shear)
    exact = closed_form_abs_K(k=shear)
    r = assess(face, lref=1.0, with_fields=False)
    v = r.validity["I_D"]
    error = abs(r.integrals.int_abs_K - exact)
    assert error <= 1e-4 * exact and error <= v.evidence["error_estimate"] * r.integrals.valid_area
    # |K| ~ r^-2 against an area ~ r^3 within r: the excluded |K| integral decays like r^1
    audit, = [a for a in v.evidence["audit"] if "point" in a]
    assert np.allclose(audit["point"], (A, B), atol=1e-12, rtol=0)
    assert audit["verdict"] == "convergent" and abs(audit["decay_power"] - 1.0) < 0.05
    assert v.status.value == "VALID*"
    # the quadtree alone, refining towards the point it does not know of, leaves it unaudited
    # and, where |K| J peaks along a ray (the shear), needs many times the points
    monkeypatch.setattr(singular, "isolated_zeros", lambda *args: [])
    plain = assess(face, lref=1.0, with_fields=False)
    assert abs(plain.integrals.int_abs_K - exact) <= 1e-4 * exact
    assert not [a for a in plain.validity["I_D"].evidence.get("audit", []) if "point" in a]
    points, plain_points = v.evidence["points"], plain.validity["I_D"].evidence["points"]
    if shear:
        assert 2 * points < plain_points
