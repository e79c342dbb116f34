"""Trim curves in a face's parameter space (p-curves), evaluated on arrays.

Curve2D is what the trimmed domain needs of a curve C(s) = (U(s), V(s)): its values,
tangent directions, a sampling fine enough to bracket its u-extrema and crossings, and
its C^0 breaks. NurbsCurve2D (lines, B-spline and Bezier curves, rational or not) and
ConicArc2D (circles, ellipses) are exact numpy evaluators of OpenCascade's p-curves,
made from occ_records.pcurve_record's numbers and checked against OpenCascade's points;
FunctionCurve2D wraps vectorised callables, OccCurve2D evaluates any Geom2d curve point
by point through OpenCascade (the exact, slow fallback).
"""
import math

import numpy as np

from ...core.errors import InputError
from .nurbs import basis_derivatives
from .span_polynomials import SpanPolynomials
from ..reading.occ_records import pcurve_record, xy

#: Samples per polynomial span of a p-curve (bracketing of u-extrema and crossings).
SAMPLES_PER_SPAN = 16
#: Samples of a full turn of a circle or ellipse.
SAMPLES_PER_TURN = 64


class Curve2D:
    """A 2D curve C(s) = (U(s), V(s)), s in [s0, s1], evaluated on arrays.

    Subclasses provide value(s) -> (n, 2) and derivative(s) -> (n, 2) (a positive multiple
    of dC/ds is enough: only its direction and sign are used), sample_params() (k,)
    increasing and including s0, s1, and breaks (interior parameters where C is only C^0).
    """

    s0 = 0.0
    s1 = 1.0
    breaks = ()
    horizontal_v = None  # exact v of a horizontal straight curve, else None

    def value(self, s):
        raise NotImplementedError

    def derivative(self, s):
        raise NotImplementedError

    def sample_params(self):
        return np.linspace(self.s0, self.s1, 33)

    #: True when value_and_derivative gives the exact dC/ds (Newton steps may use it).
    exact_derivative = False

    def value_and_derivative(self, s):
        return self.value(s), self.derivative(s)


class NurbsCurve2D(Curve2D):
    """Rational B-spline curve C(s) = sum N_ip(s) w_i P_i / sum N_ip(s) w_i, s in [s0, s1].

    knots: flat knot vector (len(poles) + degree + 1,); poles (n, 2); weights (n,) or None.
    """

    def __init__(self, degree, knots, poles, weights=None, s0=None, s1=None):
        self.degree = int(degree)
        self.knots = np.asarray(knots, dtype=float)
        self.poles = np.asarray(poles, dtype=float).reshape(-1, 2)
        n = len(self.poles)
        if self.knots.size != n + self.degree + 1:
            raise InputError("B-spline p-curve: %d knots for %d poles of degree %d"
                             % (self.knots.size, n, self.degree))
        self.weights = np.ones(n) if weights is None else np.asarray(weights, dtype=float)
        self.rational = not np.all(self.weights == self.weights[0])
        self.s0 = float(self.knots[self.degree] if s0 is None else s0)
        self.s1 = float(self.knots[n] if s1 is None else s1)
        distinct, mult = np.unique(self.knots, return_counts=True)
        inside = (distinct > self.s0) & (distinct < self.s1)
        self.knot_values = distinct[inside]
        self.breaks = tuple(distinct[inside & (mult >= self.degree)])
        vs = self.poles[:, 1]
        span_v = np.ptp(vs)
        self.horizontal_v = float(vs[0]) if span_v <= 1e-15 * max(1.0, abs(vs[0])) else None
        self._basis = None  # SpanPolynomials, made at the first evaluation

    @classmethod
    def line(cls, p0, p1, s0=0.0, s1=1.0):
        """The segment from p0 to p1, affine in s on [s0, s1]."""
        return cls(1, [s0, s0, s1, s1], [p0, p1])

    def _eval(self, s):
        s = np.asarray(s, dtype=float).ravel()
        p = self.degree
        if self._basis is None:
            self._basis = SpanPolynomials(self.knots, p, basis_derivatives)
        span = self._basis.spans(s)
        B = self._basis.basis(span, s, order=1)
        N, dN = B[0].T, B[1].T
        idx = span[:, None] - p + np.arange(p + 1)[None, :]
        w = self.weights[idx]
        P = self.poles[idx]
        Nw, dNw = N * w, dN * w
        W, dW = Nw.sum(1), dNw.sum(1)
        A = np.einsum("nk,nkd->nd", Nw, P)
        dA = np.einsum("nk,nkd->nd", dNw, P)
        C = A / W[:, None]
        return C, (dA - dW[:, None] * C) / W[:, None]

    def value(self, s):
        return self._eval(s)[0]

    def derivative(self, s):
        return self._eval(s)[1]

    exact_derivative = True

    def value_and_derivative(self, s):
        return self._eval(s)

    def sample_params(self):
        edges = np.concatenate(([self.s0], self.knot_values, [self.s1]))
        k = SAMPLES_PER_SPAN if self.degree > 1 else 1
        t = np.linspace(0.0, 1.0, k + 1)[:-1]
        inner = (edges[:-1, None] + np.diff(edges)[:, None] * t[None, :]).ravel()
        return np.concatenate((inner, [self.s1]))


class ConicArc2D(Curve2D):
    """Circle or ellipse arc C(s) = c + rx cos(s) X + ry sin(s) Y, s in [s0, s1]."""

    def __init__(self, center, xaxis, yaxis, rx, ry, s0=0.0, s1=2.0 * math.pi):
        self.center = np.asarray(center, dtype=float)
        self.ax = float(rx) * np.asarray(xaxis, dtype=float)
        self.ay = float(ry) * np.asarray(yaxis, dtype=float)
        self.s0, self.s1 = float(s0), float(s1)

    @classmethod
    def circle(cls, center, radius, clockwise=False):
        """Full circle about center, counter-clockwise in (u, v) unless clockwise."""
        return cls(center, (1.0, 0.0), (0.0, -1.0 if clockwise else 1.0), radius, radius)

    def value(self, s):
        s = np.asarray(s, dtype=float).ravel()
        return self.center + np.cos(s)[:, None] * self.ax + np.sin(s)[:, None] * self.ay

    def derivative(self, s):
        s = np.asarray(s, dtype=float).ravel()
        return -np.sin(s)[:, None] * self.ax + np.cos(s)[:, None] * self.ay

    exact_derivative = True

    def sample_params(self):
        k = max(8, int(math.ceil(SAMPLES_PER_TURN * abs(self.s1 - self.s0) / (2 * math.pi))))
        return np.linspace(self.s0, self.s1, k + 1)


class FunctionCurve2D(Curve2D):
    """Curve given by vectorised callables value(s) -> (n, 2), derivative(s) -> (n, 2)."""

    def __init__(self, value, derivative, s0, s1, n_samples=128, breaks=()):
        self._value, self._derivative = value, derivative
        self.s0, self.s1 = float(s0), float(s1)
        self.n_samples = int(n_samples)
        self.breaks = tuple(breaks)

    def value(self, s):
        s = np.asarray(s, dtype=float).ravel()
        return np.asarray(self._value(s), dtype=float).reshape(-1, 2)

    def derivative(self, s):
        return np.asarray(self._derivative(np.asarray(s, dtype=float).ravel()),
                          dtype=float).reshape(-1, 2)

    def sample_params(self):
        return np.linspace(self.s0, self.s1, self.n_samples + 1)


class OccCurve2D(Curve2D):
    """Any Geom2d curve, evaluated point by point by OpenCascade (exact, slow fallback).

    derivative() returns the unit tangent (a positive multiple of dC/ds).
    """

    def __init__(self, geom2d, s0, s1, n_samples=256):
        self.geom = geom2d
        self.s0, self.s1 = float(s0), float(s1)
        self.n_samples = n_samples

    @staticmethod
    def _points(method, s):
        return np.array([xy(method(float(x))) for x in np.asarray(s, dtype=float).ravel()],
                        dtype=float).reshape(-1, 2)

    def value(self, s):
        return self._points(self.geom.value, s)

    def derivative(self, s):
        return self._points(self.geom.tangent, s)

    def sample_params(self):
        return np.linspace(self.s0, self.s1, self.n_samples + 1)


def curve_from_record(rec):
    """Exact numpy evaluator of a p-curve from occ_records.pcurve_record's data: a line as
    a degree-1 B-spline (Line2d is affine in its parameter), a circle or ellipse as a
    :class:`ConicArc2D`, a B-spline or Bezier curve as a :class:`NurbsCurve2D`; None when the
    conversion does not reproduce OpenCascade's points (the record's check samples) to 1e-12
    of the curve's size."""
    s0, s1 = rec["s0"], rec["s1"]
    kind = rec["kind"]
    if kind == "line":
        curve = NurbsCurve2D.line(rec["p0"], rec["p1"], s0, s1)
    elif kind == "conic":
        curve = ConicArc2D(rec["center"], rec["xaxis"], rec["yaxis"], rec["rx"], rec["ry"], s0, s1)
    elif kind == "nurbs":
        curve = NurbsCurve2D(rec["degree"], rec["knots"], rec["poles"], rec["weights"], s0, s1)
    else:
        return None
    s = np.array(rec["check_s"], dtype=float)
    ref = np.array(rec["check_uv"], dtype=float)
    size = max(1.0, float(np.abs(ref).max()))
    if np.abs(curve.value(s) - ref).max() > 1e-12 * size:
        return None
    return curve


def curve_from_geom2d(geom, s0, s1):
    """Exact numpy evaluator of a FreeCAD Geom2d curve on [s0, s1]: curve_from_record of its
    occ_records.pcurve_record (a periodic B-spline unperiodised on a copy, which keeps its
    parameterisation); any other type, or a conversion that fails its check, falls back to
    :class:`OccCurve2D`."""
    rec = pcurve_record(geom, s0, s1)
    curve = None if rec is None else curve_from_record(rec)
    return curve if curve is not None else OccCurve2D(geom, float(s0), float(s1))
