"""Batched evaluation of B-spline, Bezier and rational (NURBS) surfaces.

A tensor-product surface of degrees (p, q) with flat knot vectors U, V, poles P_ij
and weights w_ij is (eq:brep_surface)

    S(u, v) = A(u, v) / w(u, v),   A = sum_ij N_ip(u) N_jq(v) w_ij P_ij,
                                   w = sum_ij N_ip(u) N_jq(v) w_ij,

with w_ij = 1 for a non-rational surface (then S = A). The basis functions and their
first and second derivatives come from their polynomial tables span by span
(span_polynomials), made with the Cox-de Boor triangle and its derivative recurrence
(algorithms A2.2/A2.3 of Piegl and Tiller, The NURBS Book, basis_derivatives here,
vectorised over the points); rational derivatives follow from the quotient rule applied to
the homogeneous coordinates (A, w).

Spans are located with ``np.searchsorted`` and clamped to the first and last non-empty
span, so evaluation exactly at the end of the domain uses the last span (left limit)
and interior knots are right-continuous. Periodic directions are evaluated on the
un-periodised pole/knot arrays of a copy of the surface (``setUNotPeriodic`` keeps the
parameterisation) after reducing parameters outside the base period into it.

rounding(u, v) bounds the rounding of the computed derivatives: a contraction
sum_ij N_i^(k)(u) N_j^(l)(v) Pw_ij of n = (p + 1)(q + 1) terms is within gamma_n sum_ij
|N_i^(k)| |N_j^(l)| |Pw_ij| of its exact value (Higham, Accuracy and Stability of Numerical
Algorithms, eq. 3.5), taken as ROUNDING_TERMS n eps R sum_i |N_i^(k)| sum_j |N_j^(l)| with R
the largest pole distance from the poles' centre (rational: of the homogeneous poles, and of
w times S in the quotient rule, over the smallest weight); the factor ROUNDING_TERMS covers
the basis values' own rounding, of the same size.
"""
import math
from dataclasses import dataclass, field
from typing import Optional, Tuple

import numpy as np

from ...core.errors import InputError
from ..cubature.cells import grid_points
from ..reading.occ_records import nurbs_record
from .span_polynomials import SpanPolynomials

#: Points evaluated per block; bounds the temporary (4, p+1, q+1, block) pole gather.
CHUNK = 8192
#: Grids evaluated per block by evaluate_grid; bounds its products (block x 9 a b x 4 floats).
GRID_CHUNK = 1024
#: Multiple of the contraction's n eps in the derivatives' rounding bounds (module doc).
ROUNDING_TERMS = 2.0
#: Orders (k, l) of d^k/du^k d^l/dv^l S in the order evaluate returns them: S, Su, Sv, Suu,
#: Suv, Svv.
PAIRS = ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2))


def as_points(u, v):
    """Broadcast parameters to two flat float arrays of equal length n."""
    try:
        uu, vv = np.broadcast_arrays(np.asarray(u, dtype=float), np.asarray(v, dtype=float))
    except ValueError as exc:
        raise InputError("parameter arrays u and v have incompatible shapes: %s" % exc) from exc
    return np.ascontiguousarray(uu).ravel(), np.ascontiguousarray(vv).ravel()



def basis_derivatives(knots, degree, span, x, order=2):
    """Non-zero basis functions and derivatives, shape (order+1, degree+1, n).

    ``out[k, r, m]`` is d^k/dx^k N_{span[m]-degree+r, degree}(x[m]) (NURBS book A2.2/A2.3,
    vectorised over the points m); derivative orders above the degree are zero.
    """
    p = degree
    n = x.shape[0]
    ndu = np.empty((p + 1, p + 1, n))
    left = np.empty((p + 1, n))
    right = np.empty((p + 1, n))
    ndu[0, 0] = 1.0
    for j in range(1, p + 1):
        left[j] = x - knots[span + 1 - j]
        right[j] = knots[span + j] - x
        saved = np.zeros(n)
        for r in range(j):
            ndu[j, r] = right[r + 1] + left[j - r]  # knot differences (lower triangle)
            temp = ndu[r, j - 1] / ndu[j, r]
            ndu[r, j] = saved + right[r + 1] * temp
            saved = left[j - r] * temp
        ndu[j, j] = saved
    out = np.zeros((order + 1, p + 1, n))
    out[0] = ndu[:, p]
    top = min(order, p)
    for r in range(p + 1):
        a_prev = {0: 1.0}
        for k in range(1, top + 1):
            a_cur = {}
            d = 0.0
            rk, pk = r - k, p - k
            if r >= k:
                a_cur[0] = a_prev[0] / ndu[pk + 1, rk]
                d = d + a_cur[0] * ndu[rk, pk]
            j1 = 1 if rk >= -1 else -rk
            j2 = k - 1 if r - 1 <= pk else p - r
            for j in range(j1, j2 + 1):
                a_cur[j] = (a_prev[j] - a_prev[j - 1]) / ndu[pk + 1, rk + j]
                d = d + a_cur[j] * ndu[rk + j, pk]
            if r <= pk:
                a_cur[k] = -a_prev[k - 1] / ndu[pk + 1, r]
                d = d + a_cur[k] * ndu[r, pk]
            out[k, r] = d
            a_prev = a_cur
    for k in range(1, top + 1):
        out[k] *= math.factorial(p) / math.factorial(p - k)
    return out


def knot_breaks(knots, mults, degree, lo, hi, period=None, min_continuity=None):
    """Distinct knot values strictly inside (lo, hi) where a spline changes piece, (k,) float.

    knots, mults: distinct knots of the domain [first, last] and their multiplicities
    (as OCC lists them). min_continuity None: every knot (the spline is one polynomial or
    rational piece between them). An integer c: only knots where it is less smooth than
    C^c, i.e. multiplicity > degree - c. With a period the knots (first included, the seam)
    repeat every period, so (lo, hi) may extend beyond the base period.
    """
    knots = np.asarray(knots, dtype=float)
    mults = np.asarray(mults, dtype=int)
    lo, hi = float(lo), float(hi)
    if min_continuity is not None:
        keep = mults > int(degree) - int(min_continuity)
        knots = knots[keep] if period is None else knots[:-1][keep[:-1]]
    elif period is not None:
        knots = knots[:-1]
    if period is not None and knots.size:
        first = float(knots[0])
        m0 = math.floor((lo - first) / period) - 1
        m1 = math.ceil((hi - first) / period) + 1
        knots = (knots[None, :] + period * np.arange(m0, m1 + 1)[:, None]).ravel()
    knots = np.unique(knots)
    return knots[(knots > lo) & (knots < hi)]


def _distinct_with_mults(flat):
    values, mults = np.unique(np.asarray(flat, dtype=float), return_counts=True)
    return values, mults


@dataclass(eq=False)
class NurbsSurfaceData:
    """Poles, weights and knots of a B-spline/Bezier surface, ready for batched evaluation.

    udegree, vdegree : int                  degrees p, q
    uknots, vknots   : (nu+p+1,), (nv+q+1,)  flat (non-periodic) knot vectors
    poles            : (nu, nv, 3) float     Cartesian poles
    weights          : (nu, nv) float or None (None: non-rational)
    urange, vrange   : (first, last)         evaluation domain (base period if periodic)
    uperiod, vperiod : float or None         period of a periodic direction
    uknots_distinct, umults (and v)          distinct knots of the domain [first, last] with
                                             their multiplicities (periodic: as OCC lists them)
    """

    udegree: int
    vdegree: int
    uknots: np.ndarray
    vknots: np.ndarray
    poles: np.ndarray
    weights: Optional[np.ndarray] = None
    urange: Tuple[float, float] = None
    vrange: Tuple[float, float] = None
    uperiod: Optional[float] = None
    vperiod: Optional[float] = None
    uknots_distinct: np.ndarray = None
    umults: np.ndarray = None
    vknots_distinct: np.ndarray = None
    vmults: np.ndarray = None
    _pw_t: np.ndarray = field(default=None, init=False, repr=False)  # (dim, nu*nv) homogeneous poles
    _center: np.ndarray = field(default=None, init=False, repr=False)  # (3,) pole bounding-box centre
    _bases: tuple = field(default=None, init=False, repr=False)  # SpanPolynomials in u and v, when made
    _rounding_scale: float = field(default=None, init=False, repr=False)  # the bounds' n eps R (module doc)
    #: 1 / R^2 of the poles' size R: the Gaussian curvature of a sphere of that size
    curvature_scale: float = field(default=None, init=False, repr=False)

    def __post_init__(self):
        p, q = int(self.udegree), int(self.vdegree)
        if p < 1 or q < 1:
            raise InputError("NURBS surface degrees must be >= 1, got (%d, %d)" % (p, q))
        self.udegree, self.vdegree = p, q
        self.uknots = np.ascontiguousarray(self.uknots, dtype=float)
        self.vknots = np.ascontiguousarray(self.vknots, dtype=float)
        self.poles = np.ascontiguousarray(self.poles, dtype=float)
        if self.poles.ndim != 3 or self.poles.shape[2] != 3:
            raise InputError("NURBS poles must have shape (nu, nv, 3), got %s" % (self.poles.shape,))
        nu, nv = self.poles.shape[:2]
        if len(self.uknots) != nu + p + 1 or len(self.vknots) != nv + q + 1:
            raise InputError(
                "NURBS knot vectors have lengths (%d, %d); %d x %d poles of degrees (%d, %d) need (%d, %d)"
                % (len(self.uknots), len(self.vknots), nu, nv, p, q, nu + p + 1, nv + q + 1))
        if np.any(np.diff(self.uknots) < 0) or np.any(np.diff(self.vknots) < 0):
            raise InputError("NURBS knot vectors must be non-decreasing")
        if self.weights is not None:
            self.weights = np.ascontiguousarray(self.weights, dtype=float)
            if self.weights.shape != (nu, nv):
                raise InputError("NURBS weights must have shape %s, got %s" % ((nu, nv), self.weights.shape))
            if not np.all(self.weights > 0):
                raise InputError("NURBS weights must be positive")
        if self.urange is None:
            self.urange = (float(self.uknots[p]), float(self.uknots[nu]))
        if self.vrange is None:
            self.vrange = (float(self.vknots[q]), float(self.vknots[nv]))
        if self.uknots_distinct is None:
            self.uknots_distinct, self.umults = _distinct_with_mults(self.uknots[p:nu + 1])
        if self.vknots_distinct is None:
            self.vknots_distinct, self.vmults = _distinct_with_mults(self.vknots[q:nv + 1])
        self.uknots_distinct = np.asarray(self.uknots_distinct, dtype=float)
        self.vknots_distinct = np.asarray(self.vknots_distinct, dtype=float)
        self.umults = np.asarray(self.umults, dtype=int)
        self.vmults = np.asarray(self.vmults, dtype=int)
        # poles relative to their bounding-box centre: derivatives are translation-invariant,
        # and small coordinates lose fewer digits in sum_i N_i^(k) P_i (sum_i N_i^(k) = 0, k > 0)
        self._center = 0.5 * (self.poles.reshape(-1, 3).min(axis=0) + self.poles.reshape(-1, 3).max(axis=0))
        local = self.poles - self._center
        if self.weights is None:
            pw = local
        else:
            pw = np.concatenate([local * self.weights[..., None], self.weights[..., None]], axis=2)
        self._pw_t = np.ascontiguousarray(pw.reshape(nu * nv, pw.shape[2]).T)  # (dim, nu*nv)
        R = size = float(np.sqrt((local * local).sum(2)).max())
        if self.weights is not None:
            w = self.weights
            R = (float(np.sqrt((pw[..., :3] ** 2).sum(2)).max()) + float(w.max()) * size) / float(w.min())
        self._rounding_scale = ROUNDING_TERMS * (p + 1) * (q + 1) * np.finfo(float).eps * R
        self.curvature_scale = 1.0 / size ** 2 if size > 0 else 0.0

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_surface(cls, surface):
        """Extract the data of a Part.BSplineSurface or Part.BezierSurface (not modified)."""
        rec = nurbs_record(surface)
        if rec is None:
            raise InputError("expected a Part.BSplineSurface or Part.BezierSurface, got %s"
                             % type(surface).__name__)
        return cls.from_record(rec)

    @classmethod
    def from_record(cls, rec):
        """From occ_records.nurbs_record's plain data (the same numbers)."""
        rec = dict(rec)
        poles = np.array(rec.pop("poles"), dtype=float)
        weights = rec.pop("weights")
        weights = None if weights is None else np.array(weights, dtype=float)
        for k in ("uknots_distinct", "vknots_distinct"):
            if k in rec:
                rec[k] = np.array(rec[k], dtype=float)
        for k in ("umults", "vmults"):
            if k in rec:
                rec[k] = np.array(rec[k], dtype=int)
        return cls(rec.pop("udegree"), rec.pop("vdegree"), np.array(rec.pop("uknots"), dtype=float),
                   np.array(rec.pop("vknots"), dtype=float), poles, weights, **rec)

    # ------------------------------------------------------------------ properties
    @property
    def rational(self):
        return self.weights is not None

    @property
    def shape(self):
        """(nu, nv): number of poles in u and v."""
        return self.poles.shape[:2]

    def _dir(self, direction):
        if direction == "u":
            return self.uknots_distinct, self.umults, self.uperiod, self.udegree, self.urange
        if direction == "v":
            return self.vknots_distinct, self.vmults, self.vperiod, self.vdegree, self.vrange
        raise InputError("direction must be 'u' or 'v', got %r" % (direction,))

    def breaks(self, direction, lo=None, hi=None, min_continuity=None):
        """Knot lines strictly inside (lo, hi) (default: the domain), sorted, (k,) float.

        See :func:`knot_breaks` for ``min_continuity`` and periodic repetition.
        """
        knots, mults, period, degree, (first, last) = self._dir(direction)
        return knot_breaks(knots, mults, degree, first if lo is None else lo, last if hi is None else hi,
                           period=period, min_continuity=min_continuity)

    # ------------------------------------------------------------------ evaluation
    @property
    def bases(self):
        """The basis functions in u and v, span by span (SpanPolynomials), made once."""
        if self._bases is None:
            self._bases = (SpanPolynomials(self.uknots, self.udegree, basis_derivatives),
                           SpanPolynomials(self.vknots, self.vdegree, basis_derivatives))
        return self._bases

    def _wrap(self, x, period, rng):
        """Reduce periodic parameters outside [first, last] into the base period."""
        if period is None:
            return x
        first, last = rng
        out = (x < first) | (x > last)
        if np.any(out):
            x = x.copy()
            x[out] = first + np.mod(x[out] - first, period)
        return x

    def _parameters(self, u, v):
        """u, v as flat arrays of equal length (as_points), periodic ones in the base period."""
        u, v = as_points(u, v)
        return self._wrap(u, self.uperiod, self.urange), self._wrap(v, self.vperiod, self.vrange)

    def points(self, u, v):
        """Surface points S(u, v), (n, 3) float."""
        return self.evaluate(u, v, order=0)[0]

    def derivatives(self, u, v):
        """(S, Su, Sv, Suu, Suv, Svv) at (u, v), each (n, 3) float."""
        return self.evaluate(u, v, order=2)

    def evaluate(self, u, v, order=2):
        """S and partial derivatives up to total order ``order`` (0, 1 or 2).

        Returns (S,), (S, Su, Sv) or (S, Su, Sv, Suu, Suv, Svv), each (n, 3) float.
        """
        if order not in (0, 1, 2):
            raise InputError("derivative order must be 0, 1 or 2, got %r" % (order,))
        u, v = self._parameters(u, v)
        n = u.shape[0]
        nout = (1, 3, 6)[order]
        out = [np.empty((n, 3)) for _ in range(nout)]
        for s in range(0, n, CHUNK):
            e = min(n, s + CHUNK)
            block = self._evaluate_block(u[s:e], v[s:e], order)
            for o, b in zip(out, block):
                o[s:e] = b
        out[0] += self._center
        return tuple(out)

    def rounding(self, u, v):
        """Bounds (n, 5) of the rounding of the computed Su, Sv, Suu, Suv, Svv at (u, v)
        (their vector norms, module doc): ROUNDING_TERMS n eps R times the products of the
        sums of |basis| (and its derivatives) in u and in v, bounded over each knot span
        (SpanPolynomials.abs_sum_bounds)."""
        u, v = self._parameters(u, v)
        bu, bv = self.bases
        au = bu.abs_sum_bounds(bu.spans(u))  # (3, n): bounds of sum |N|, |N'|, |N''|
        av = bv.abs_sum_bounds(bv.spans(v))
        r = np.empty((u.size, 5))
        for col, (k, l) in enumerate(PAIRS[1:]):
            np.multiply(au[k], self._rounding_scale * av[l], out=r[:, col])
        return r

    def evaluate_grid(self, u, v, order=2):
        """S and partial derivatives on tensor grids: u (n, a) and v (n, b) give the points
        (u[c, i], v[c, j]), returned as evaluate() returns them for the broadcast grids
        (flat, in [c, i, j] order).

        A grid whose u and v each lie in one knot span shares its basis functions and its
        (p+1) x (q+1) poles: d^k/du^k d^l/dv^l Sw(u_i, v_j) = sum_a N_a^(k)(u_i) sum_b
        N_b^(l)(v_j) Pw_ab, two small matrix products per grid instead of one contraction per
        point (NURBS book A3.6 over a grid); grids that cross a knot go point by point.
        """
        if order not in (0, 1, 2):
            raise InputError("derivative order must be 0, 1 or 2, got %r" % (order,))
        u = np.asarray(u, dtype=float)
        v = np.asarray(v, dtype=float)
        if u.ndim != 2 or v.ndim != 2 or u.shape[0] != v.shape[0]:
            raise InputError("evaluate_grid needs u (n, a) and v (n, b), got %s and %s" % (u.shape, v.shape))
        n, a = u.shape
        b = v.shape[1]
        u = self._wrap(u.ravel(), self.uperiod, self.urange).reshape(n, a)
        v = self._wrap(v.ravel(), self.vperiod, self.vrange).reshape(n, b)
        bu, bv = self.bases
        su = bu.spans(u.ravel()).reshape(n, a)
        sv = bv.spans(v.ravel()).reshape(n, b)
        one = (su == su[:, :1]).all(1) & (sv == sv[:, :1]).all(1)
        nout = (1, 3, 6)[order]
        # made as x, y, z rows (3, n a b) and handed on as their transposes: the curvature's
        # arithmetic takes the rows as they are (differential._components) instead of a copy
        out = [np.empty((3, n, a, b)) for _ in range(nout)]
        rows = np.nonzero(one)[0]
        for s in range(0, rows.size, GRID_CHUNK):
            r = rows[s:s + GRID_CHUNK]
            # consecutive grids (the usual case) are written through a slice, not scattered
            at = slice(r[0], r[-1] + 1) if r[-1] - r[0] == r.size - 1 else r
            for o, g in zip(out, self._grid_block(u[r], v[r], su[r, 0], sv[r, 0], order)):
                o[:, at] = g
        rows = np.nonzero(~one)[0]
        if rows.size:
            for o, g in zip(out, self.evaluate(*grid_points(u[rows], v[rows]), order)):
                o[:, rows] = g.T.reshape(3, rows.size, a, b)
            out[0][:, rows] -= self._center[:, None, None, None]  # added to all below
        out = [o.reshape(3, n * a * b) for o in out]
        out[0] += self._center[:, None]
        return tuple(o.T for o in out)

    def _grid_block(self, u, v, su, sv, order):
        """evaluate_grid for grids u (m, a), v (m, b) in the spans su, sv (m,): arrays (3, m, a, b)
        relative to the poles' centre."""
        p, q = self.udegree, self.vdegree
        m, a = u.shape
        b = v.shape[1]
        L = order + 1
        dim = self._pw_t.shape[0]
        bu = self.bases[0].basis(np.repeat(su, a), u.ravel(), order)  # (L, p+1, m a)
        bv = self.bases[1].basis(np.repeat(sv, b), v.ravel(), order)  # (L, q+1, m b)
        nv = self.poles.shape[1]
        offs = np.arange(p + 1)[:, None] * nv + np.arange(q + 1)[None, :]
        ctrl = self._pw_t.T[offs.T[None] + ((su - p) * nv + (sv - q))[:, None, None]]  # (m, q+1, p+1, dim)
        # one product per grid in each direction: T[c, (l, j), (x, d)] = sum_y d^l N_y(v_cj)
        # Pw[c, x, y, d], then S[c, (k, i), (d, l, j)] = sum_x d^k N_x(u_ci) T[c, l, j, x, d],
        # every pair of derivative orders at once
        bv = bv.reshape(L, q + 1, m, b).transpose(2, 0, 3, 1).reshape(m, L * b, q + 1)
        T = np.matmul(bv, ctrl.reshape(m, q + 1, (p + 1) * dim))
        T = T.reshape(m, L, b, p + 1, dim).transpose(0, 3, 4, 1, 2).reshape(m, p + 1, dim * L * b)
        bu = bu.reshape(L, p + 1, m, a).transpose(2, 0, 3, 1).reshape(m, L * a, p + 1)
        # S[c, (k, i), (d, l, j)]: the v points innermost, so that each pair's (dim, m, a, b)
        # rows are gathered along contiguous runs
        S = np.matmul(bu, T).reshape(m, L, a, dim, L, b)
        hom = [np.moveaxis(S[:, k, :, :, l], 2, 0) for k, l in PAIRS[:(1, 3, 6)[order]]]  # (dim, m, a, b)
        return hom if self.weights is None else rational_quotient(hom)

    def _evaluate_block(self, u, v, order):
        """Derivatives for one block of points; arrays are laid out points-last, (dim, n).
        A lone point is evaluated as a pair with itself: einsum sums a length-1 points axis
        in another order, and a point's value must not depend on its batch."""
        if u.size == 1:
            return [h[:1] for h in self._evaluate_block(np.repeat(u, 2), np.repeat(v, 2), order)]
        p, q = self.udegree, self.vdegree
        nv = self.poles.shape[1]
        basis_u, basis_v = self.bases
        su, sv = basis_u.spans(u), basis_v.spans(v)
        bu = basis_u.basis(su, u, order)  # (order+1, p+1, n)
        bv = basis_v.basis(sv, v, order)  # (order+1, q+1, n)
        base = (su - p) * nv + (sv - q)
        offs = np.arange(p + 1)[:, None] * nv + np.arange(q + 1)[None, :]
        ctrl = np.take(self._pw_t, offs[:, :, None] + base[None, None, :], axis=1)  # (dim, p+1, q+1, n)
        # contract v first: T[l, :, a] = sum_b d^l N_b(v) Pw[a, b]   -> (order+1, dim, p+1, n)
        tv = np.einsum("lbn,dabn->ldan", bv, ctrl)

        def comb(k, l):
            return np.einsum("an,dan->dn", bu[k], tv[l])

        hom = [comb(k, l) for k, l in PAIRS[:(1, 3, 6)[order]]]
        if self.weights is not None:
            hom = rational_quotient(hom)
        return [h.T for h in hom]


def rational_quotient(hom):
    """Cartesian derivatives of S = A / w from homogeneous ones (quotient rule).

    hom: list of (4, ...) arrays [Aw, Aw_u, Aw_v, Aw_uu, Aw_uv, Aw_vv] (first 1, 3 or 6),
    row 3 holding w and its derivatives. Returns as many (3, ...) arrays:
    S = A/w, S_u = (A_u - w_u S)/w, S_uu = (A_uu - 2 w_u S_u - w_uu S)/w,
    S_uv = (A_uv - w_u S_v - w_v S_u - w_uv S)/w (and symmetrically in v).
    """
    inv_w = 1.0 / hom[0][3]
    s = hom[0][:3] * inv_w
    if len(hom) == 1:
        return [s]
    w_u, w_v = hom[1][3], hom[2][3]
    s_u = (hom[1][:3] - w_u * s) * inv_w
    s_v = (hom[2][:3] - w_v * s) * inv_w
    if len(hom) == 3:
        return [s, s_u, s_v]
    s_uu = (hom[3][:3] - 2.0 * w_u * s_u - hom[3][3] * s) * inv_w
    s_uv = (hom[4][:3] - w_u * s_v - w_v * s_u - hom[4][3] * s) * inv_w
    s_vv = (hom[5][:3] - 2.0 * w_v * s_v - hom[5][3] * s) * inv_w
    return [s, s_u, s_v, s_uu, s_uv, s_vv]
