"""The span tables of B-spline basis functions (geometry.span_polynomials) against the
Cox-de Boor recurrences they are made from, and a point's value whatever its batch."""
import numpy as np
import pytest

from hullprod_wb.brep.geometry.nurbs import NurbsSurfaceData, basis_derivatives
from hullprod_wb.brep.geometry.span_polynomials import SpanPolynomials

EPS = np.finfo(float).eps


def knot_vector(rng, p, offset=100.0):
    """Clamped knots on [offset, offset + 4] with uneven spans and one double interior knot:
    coordinates far from 0, as CAD files write them, make the expansion point matter."""
    inner = np.sort(offset + 4.0 * rng.random(9))
    inner = np.sort(np.r_[inner, inner[4]])
    return np.r_[np.full(p + 1, offset), inner, np.full(p + 1, offset + 4.0)]


@pytest.mark.parametrize("p", [1, 2, 3, 5, 7, 9])
def test_tables_agree_with_the_recurrences_to_a_few_units_of_rounding(p):
    """Each derivative order (0, 1, 2) agrees with basis_derivatives within 16 eps of its
    largest value, at degrees up to 9 (about the left knot, degree 9 differs by ~600 eps),
    and equals them on the knots."""
    rng = np.random.default_rng(p)
    knots = knot_vector(rng, p)
    table = SpanPolynomials(knots, p, basis_derivatives)
    x = np.r_[knots[0] + 4.0 * rng.random(2000), np.unique(knots)]  # knots themselves too
    span = table.spans(x)
    got = table.basis(span, x, 2)
    ref = basis_derivatives(knots, p, span, x, 2)
    for k in range(min(2, p) + 1):
        scale = np.abs(ref[k]).max()
        assert np.abs(got[k] - ref[k]).max() <= 16 * EPS * scale, k
    assert np.allclose(got[0].sum(0), 1.0, rtol=0, atol=16 * EPS)  # partition of unity
    at_knots = x.size - np.unique(knots).size
    # on the knots, the recurrences' own values: exact zeros at the clamped ends
    assert np.array_equal(got[:, :, at_knots:], ref[:, :, at_knots:])
    assert not got[0, 1:, at_knots].any()
    if p < 2:
        assert not got[2].any()  # orders above the degree are zero


def test_a_point_has_the_same_derivatives_in_any_batch():
    """A rational surface evaluated at 3000 points at once, in batches of 7 and one by one:
    the same numbers to the bit (the integrals do not depend on how the points are grouped)."""
    rng = np.random.default_rng(5)
    p, q = 3, 2
    ku, kv = knot_vector(rng, p, 0.0), knot_vector(rng, q, 0.0)
    data = NurbsSurfaceData(p, q, ku, kv, 1e3 * rng.random((len(ku) - p - 1, len(kv) - q - 1, 3)),
                            0.5 + rng.random((len(ku) - p - 1, len(kv) - q - 1)))
    u, v = 4.0 * rng.random(3000), 4.0 * rng.random(3000)
    whole = np.stack(data.derivatives(u, v))
    sevens = np.concatenate([np.stack(data.derivatives(u[s:s + 7], v[s:s + 7]))
                             for s in range(0, u.size, 7)], axis=1)
    assert np.array_equal(whole, sevens)
    ones = np.concatenate([np.stack(data.derivatives(u[s:s + 1], v[s:s + 1])) for s in range(200)], axis=1)
    assert np.array_equal(whole[:, :200], ones)
