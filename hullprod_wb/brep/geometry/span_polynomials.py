"""B-spline basis functions as polynomials on their knot spans, for evaluation in batches.

On the span [U_i, U_i+1) the p + 1 non-zero basis functions N_{i-p+r, p} (r = 0..p) are
polynomials of degree p. Their Taylor coefficients at a point c, a_rk = N^(k)(c) / k! (the
Cox-de Boor triangle and its derivative recurrence, NURBS book A2.2/A2.3), give
d^d/dx^d N_r(x) = sum_j a_r,j+d (j + d)! / j! t^j with t = x - c: one gather of a table
and one product per batch of points, whatever the degree, instead of the recurrences'
O(p^2) array operations per call. Each span keeps three expansions: about its midpoint
for the points inside (|t| <= (U_i+1 - U_i) / 2, where the power basis stays within a few
units of rounding of the recurrences up to degree 9; about a knot it loses one to three
digits there), and about its two knots for the points on them (t = 0: the recurrences'
values there, exact zeros at clamped ends and collapsed sides included; at U_i+1
the span's left limit). Every batch, of any size, takes the tables, so a point's value
does not depend on the batch it is evaluated in.
"""
import math

import numpy as np


class SpanPolynomials:
    """The basis functions of one flat knot vector of degree p, span by span.

    spans(x): the span index i of every x (knots[i] <= x < knots[i+1]), clamped to the
    first and last non-empty spans; basis(span, x, order): the non-zero basis functions and
    their derivatives, (order + 1, p + 1, n), out[k, r, m] = d^k/dx^k N_{span[m]-p+r, p}(x[m])
    (derivative orders above p are zero). recurrence: nurbs.basis_derivatives, which makes
    the tables."""

    def __init__(self, knots, degree, recurrence):
        self.knots = np.ascontiguousarray(knots, dtype=float)
        self.p = p = int(degree)
        n_poles = len(self.knots) - p - 1
        nonempty = np.nonzero(self.knots[p:n_poles] < self.knots[p + 1:n_poles + 1])[0] + p
        self.first, self.last = int(nonempty[0]), int(nonempty[-1])
        n_spans = n_poles - p
        left, right = self.knots[p:n_poles], self.knots[p + 1:n_poles + 1]
        centre = 0.5 * (left + right)
        # three expansions a span i: row 3 (i - p) about its midpoint, + 1 about U_i, + 2
        # about U_i+1 (the span's polynomial there, its left limit); empty spans are never used
        self.origin = np.stack((centre, left, right), axis=1).ravel()
        rows = (3 * (nonempty - p)[:, None] + np.arange(3)[None, :]).ravel()
        taylor = np.zeros((p + 1, p + 1, 3 * n_spans))
        taylor[:, :, rows] = recurrence(self.knots, p, np.repeat(nonempty, 3), self.origin[rows], order=p)
        fact = np.array([math.factorial(k) for k in range(p + 1)], dtype=float)
        a = taylor / fact[:, None, None]  # a[k, r, row]
        # table[row, d, r, j] = a[j + d, r] (j + d)! / j!: the j-th power's coefficient of
        # the d-th derivative
        table = np.zeros((3 * n_spans, p + 1, p + 1, p + 1))
        for d in range(p + 1):
            for j in range(p + 1 - d):
                table[:, d, :, j] = (a[j + d] * (fact[j + d] / fact[j])).T
        self.table = np.ascontiguousarray(table)
        self._abs_bounds = None

    def abs_sum_bounds(self, span):
        """Upper bounds (3, n) of sum_r |d^k/dx^k N_r| (k = 0, 1, 2) over the whole knot span
        of each span index: the sums of |coefficient| (h / 2)^j of the expansions about the
        midpoints (|t| <= h / 2 on a span of width h), made once."""
        if self._abs_bounds is None:
            p = self.p
            h = self.origin[2::3] - self.origin[1::3]  # the spans' widths
            half = np.power.outer(0.5 * h, np.arange(p + 1))  # (spans, p + 1): (h / 2)^j
            mid = self.table[0::3, :min(2, p) + 1]  # (spans, d, r, j) about the midpoints
            bounds = np.zeros((h.size, 3))
            bounds[:, :mid.shape[1]] = np.einsum("sdrj,sj->sd", np.abs(mid), half)
            self._abs_bounds = bounds
        return self._abs_bounds[span - self.p].T

    def spans(self, x):
        span = np.searchsorted(self.knots, x, side="right") - 1
        return np.minimum(np.maximum(span, self.first), self.last)

    def basis(self, span, x, order=2):
        p = self.p
        first = 3 * (span - p)
        row = first + np.where(x == self.origin[first + 1], 1, np.where(x == self.origin[first + 2], 2, 0))
        t = x - self.origin[row]
        powers = np.empty((t.size, p + 1))
        powers[:, 0] = 1.0
        for j in range(1, p + 1):
            powers[:, j] = powers[:, j - 1] * t
        top = min(order, p)
        out = np.zeros((order + 1, p + 1, t.size))
        out[:top + 1] = np.einsum("ndrj,nj->drn", self.table[row, :top + 1], powers)
        return out
