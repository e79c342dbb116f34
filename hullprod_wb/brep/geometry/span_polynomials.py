"""B-spline basis functions as polynomials on their knot spans, for evaluation in batches.

On the span [U_i, U_i+1) the p + 1 non-zero basis functions N_{i-p+r, p} (r = 0..p) are
polynomials of degree p. Their Taylor coefficients at U_i, c_rk = N^(k)(U_i) / k! (right
limits: the Cox-de Boor triangle and its derivative recurrence, NURBS book A2.2/A2.3, at the
span's left knot), give d^d/dx^d N_r(x) = sum_j c_r,j+d (j + d)! / j! t^j with t = x - U_i:
one gather of a span's table and one product per batch of points, whatever the degree,
instead of the recurrences' O(p^2) array operations per call (for the small batches of
line crossings and trim curves, where those operations' overhead is the cost).
"""
import math

import numpy as np

#: Batches of at most this many points take the span tables; larger ones the recurrences,
#: whose O(p^2) operations on long arrays cost less than the tables' gather (each is exact
#: to the rounding of the other).
TABLE_POINTS = 2048


class SpanPolynomials:
    """The basis functions of one flat knot vector of degree p, span by span.

    spans(x): the span index i of every x (knots[i] <= x < knots[i+1]), clamped to the
    first and last non-empty spans; basis(span, x, order): the non-zero basis functions and
    their derivatives, (order + 1, p + 1, n), out[k, r, m] = d^k/dx^k N_{span[m]-p+r, p}(x[m])
    (derivative orders above p are zero). recurrence: the recurrences themselves
    (nurbs.basis_derivatives), which make the tables and take the large batches."""

    def __init__(self, knots, degree, recurrence):
        self.knots = np.ascontiguousarray(knots, dtype=float)
        self.p = p = int(degree)
        n_poles = len(self.knots) - p - 1
        nonempty = np.nonzero(self.knots[p:n_poles] < self.knots[p + 1:n_poles + 1])[0] + p
        self.first, self.last = int(nonempty[0]), int(nonempty[-1])
        idx = np.arange(p, n_poles)
        # derivatives of every order up to p at each span's left knot (right limits)
        taylor = recurrence(self.knots, p, idx, self.knots[idx], order=p)  # (p+1, p+1, spans)
        taylor = np.where((self.knots[idx] < self.knots[idx + 1])[None, None, :], taylor, 0.0)
        fact = np.array([math.factorial(k) for k in range(p + 1)], dtype=float)
        c = taylor / fact[:, None, None]  # c[k, r, span]
        # table[span, d, r, j] = c[j + d, r] (j + d)! / j!: the j-th power's coefficient of
        # the d-th derivative
        table = np.zeros((idx.size, p + 1, p + 1, p + 1))
        for d in range(p + 1):
            for j in range(p + 1 - d):
                table[:, d, :, j] = (c[j + d] * (fact[j + d] / fact[j])).T
        self.table = np.ascontiguousarray(table)
        self.recurrence = recurrence

    def spans(self, x):
        span = np.searchsorted(self.knots, x, side="right") - 1
        return np.minimum(np.maximum(span, self.first), self.last)

    def basis(self, span, x, order=2):
        p = self.p
        if x.size > TABLE_POINTS:
            return self.recurrence(self.knots, p, span, x, order)
        t = x - self.knots[span]
        powers = np.empty((t.size, p + 1))
        powers[:, 0] = 1.0
        for j in range(1, p + 1):
            powers[:, j] = powers[:, j - 1] * t
        top = min(order, p)
        out = np.zeros((order + 1, p + 1, t.size))
        out[:top + 1] = np.einsum("ndrj,nj->drn", self.table[span - p, :top + 1], powers)
        return out
