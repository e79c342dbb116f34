"""Trimmed parameter domain Omega of a BRep face (paper eq:brep_surface_integral).

Omega is the part of the (u, v) plane enclosed by the face's trim loops, given exactly by
the edges' p-curves (2D curves in the face's parameter space). Points are inside by the
even-odd rule, so the loops' orientation and order do not matter; a seam edge contributes
both of its p-curves, a degenerated edge its (non-degenerate) p-curve.

Each p-curve is split into pieces on which u = U(s) is strictly monotone (at its
u-extrema and at corners). A vertical line u = const meets a piece at most once, found by
bracketing on a cached sampling of the piece and refining with vectorised Chandrupatla
iteration (inverse quadratic interpolation with bisection safeguard) on the exact curve,
to a few ulps of the curve parameter. Piece end values of u closer than the loops'
closure gap are snapped together, and a piece covers the half-open range [u_lo, u_hi),
so that a line through a vertex is counted once.

Between consecutive breakpoints (vertices, u-extrema, corner knots) the same pieces cross
every vertical line in the same v order, so Omega restricted to a slab u0 < u < u1 is a
union of strips lo_j(u) <= v <= hi_j(u), each bound by a piece (or a constant v when the
piece is a horizontal line), which is what the quadrature integrates over.

Faces read from files may need exact repairs, which TrimmedDomain.from_face makes and
lists in ``repairs``: a wrong or missing p-curve on a plane becomes the affine image of
the edge's 3-D curve, and loops left open at a vertex are closed by a parameter segment
whose image stays inside that vertex's tolerance ball (a collapsed side of the surface,
or a gap within the shape's own tolerance); otherwise the loops stay an InputError.
"""
import math

import numpy as np

from ..core.errors import InputError
from .nurbs import basis_derivatives, find_spans
from .plain_records import edge_vertices, face_pcurves, pcurve_record, xy

#: Samples per polynomial span of a p-curve (bracketing of u-extrema and crossings).
SAMPLES_PER_SPAN = 16
#: Samples of a full turn of a circle or ellipse.
SAMPLES_PER_TURN = 64
#: Relative parameter tolerance below which two breakpoint values are the same.
SNAP_RTOL = 1e-11
#: Loops whose end points are further apart than this fraction of the domain's size are open.
CLOSURE_RTOL = 1e-5
#: OpenCascade's Precision::Confusion (model units): points closer than this coincide.
PRECISION_CONFUSION = 1e-7
#: Points of an edge at which a plane's p-curve is compared with the edge's 3-D curve.
PLANE_CHECK_SAMPLES = 9
#: Points of a closing parameter segment checked against its vertex's tolerance ball.
GAP_SAMPLES = 33


class OpenTrimLoops(InputError):
    """The trim curves do not form closed loops.

    ends (2n, 2) float: start and end point of each curve (curve i has ends 2i, 2i + 1);
    open_ends (k,) int: indices of the ends with no other end within ``tolerance``.
    """

    def __init__(self, message, ends, open_ends, tolerance):
        super().__init__(message)
        self.ends, self.open_ends, self.tolerance = ends, open_ends, tolerance


# ---------------------------------------------------------------------------------------------
# vectorised bracketed root finding


def solve_bracketed(fun, x0, x1, f0, f1, xtol, maxiter=100):
    """Roots of fun in the brackets [x0, x1] with f0 * f1 <= 0, all at once, (n,) float.

    fun(x, index) evaluates the function at x (m,) for the brackets index (m,) int; one
    call per iteration for all brackets still active. Chandrupatla's method, started with a
    regula falsi step: inverse quadratic interpolation when the last three points allow
    it, bisection otherwise, with
    steps at least the tolerance away from the bracket ends; a bracket ends when it is
    narrower than about xtol (scalar or (n,)) + 4 eps |x|, at an exact zero, or at a
    non-finite value. Returns the bracket end of smaller |f|.
    """
    b = np.array(x0, dtype=float, copy=True).ravel()
    a = np.array(x1, dtype=float, copy=True).ravel()
    fb = np.array(f0, dtype=float, copy=True).ravel()
    fa = np.array(f1, dtype=float, copy=True).ravel()
    c, fc = a.copy(), fa.copy()
    n = a.size
    xtol = np.broadcast_to(np.asarray(xtol, dtype=float), (n,))
    # first step: regula falsi (then inverse quadratic interpolation or bisection)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.nan_to_num(fa / (fa - fb), nan=0.5)
    tl0 = np.minimum((2.0 * np.finfo(float).eps * np.abs(a) + 0.5 * xtol)
                     / np.maximum(np.abs(b - a), 1e-300), 0.5)
    t = np.clip(t, tl0, 1.0 - tl0)
    xm = np.where(np.abs(fa) < np.abs(fb), a, b)
    active = (fa != 0.0) & (fb != 0.0)
    for _ in range(maxiter):
        i = np.nonzero(active)[0]
        if i.size == 0:
            break
        ai, bi, fai, fbi = a[i], b[i], fa[i], fb[i]
        xt = ai + t[i] * (bi - ai)
        ft = np.asarray(fun(xt, i), dtype=float)
        same = np.sign(ft) == np.sign(fai)
        ci = np.where(same, ai, bi)
        fci = np.where(same, fai, fbi)
        bi = np.where(same, bi, ai)
        fbi = np.where(same, fbi, fai)
        ai, fai = xt, ft
        better = np.abs(fai) < np.abs(fbi)
        xmi = np.where(better, ai, bi)
        fm = np.where(better, fai, fbi)
        tol = 2.0 * np.finfo(float).eps * np.abs(xmi) + 0.5 * xtol[i]
        with np.errstate(divide="ignore", invalid="ignore"):
            tl = tol / np.abs(bi - ci)
            xi = (ai - bi) / (ci - bi)
            phi = (fai - fbi) / (fci - fbi)
            iqi = (phi * phi < xi) & ((1.0 - phi) ** 2 < 1.0 - xi)
            tn = (fai / (fbi - fai) * fci / (fbi - fci)
                  + (ci - ai) / (bi - ai) * fai / (fci - fai) * fbi / (fci - fbi))
        tn = np.where(iqi & np.isfinite(tn), tn, 0.5)
        tl = np.minimum(np.nan_to_num(tl, nan=1.0), 0.5)
        a[i], b[i], c[i], fa[i], fb[i], fc[i], xm[i] = ai, bi, ci, fai, fbi, fci, xmi
        t[i] = np.clip(tn, tl, 1.0 - tl)
        active[i[(tl >= 0.5) | (fm == 0.0) | ~np.isfinite(ft)]] = False
    return xm


# ---------------------------------------------------------------------------------------------
# 2D curves in parameter space


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

    @classmethod
    def line(cls, p0, p1, s0=0.0, s1=1.0):
        """The segment from p0 to p1, affine in s on [s0, s1]."""
        return cls(1, [s0, s0, s1, s1], [p0, p1])

    def _eval(self, s):
        s = np.asarray(s, dtype=float).ravel()
        p = self.degree
        span = find_spans(self.knots, p, s)
        B = basis_derivatives(self.knots, p, span, s, order=1)
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
    """Exact numpy evaluator of a p-curve from plain_records.pcurve_record's data: a line as
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
    plain_records.pcurve_record (a periodic B-spline unperiodised on a copy, which keeps its
    parameterisation); any other type, or a conversion that fails its check, falls back to
    :class:`OccCurve2D`."""
    rec = pcurve_record(geom, s0, s1)
    curve = None if rec is None else curve_from_record(rec)
    return curve if curve is not None else OccCurve2D(geom, float(s0), float(s1))


# ---------------------------------------------------------------------------------------------
# exact repairs of faces read from files (used by TrimmedDomain.from_face)


def _xyz(p):
    return (float(p.x), float(p.y), float(p.z))


def plane_frame(face):
    """(O, X, Y) (3,) float each when the face's surface is a plane S(u, v) = O + u X + v Y
    (X, Y orthonormal), else None. Read from S itself: O = S(0, 0), X = S(1, 0) - O,
    Y = S(0, 1) - O (exact, S is affine)."""
    surface = face.Surface
    while type(surface).__name__ == "RectangularTrimmedSurface":
        surface = surface.BasisSurface
    if type(surface).__name__ != "Plane":
        return None
    o, x, y = (np.array(_xyz(surface.value(u, v))) for u, v in ((0.0, 0.0), (1.0, 0.0), (0.0, 1.0)))
    return o, x - o, y - o


def plane_image(edge, frame):
    """Exact p-curve of a 3-D edge lying in the plane ``frame`` = (O, X, Y).

    The map x -> ((x - O).X, (x - O).Y) is affine and inverts S on the plane, so the image of
    a line is the segment between the images of its ends, of a circle or ellipse
    c + a cos s + b sin s the conic with the images of c, a, b, and of a (rational)
    B-spline or Bezier curve the curve with the images of its poles (same knots and
    weights: NURBS are affine invariant). Other curves, or an image that does not
    reproduce the edge's points to 1e-12 of its size, are mapped point by point
    (:class:`FunctionCurve2D` of Edge.valueAt). Parameter: the edge's own.
    """
    o, X, Y = frame
    L = np.array([X, Y])  # (2, 3)

    def image(points):  # (n, 3) -> (n, 2)
        return (np.asarray(points, dtype=float).reshape(-1, 3) - o) @ L.T

    s0, s1 = (float(x) for x in edge.ParameterRange)
    geom = edge.Curve
    while type(geom).__name__ == "TrimmedCurve":
        geom = geom.BasisCurve
    kind = type(geom).__name__
    curve = None
    if kind in ("Line", "LineSegment"):
        ends = image([_xyz(edge.valueAt(s0)), _xyz(edge.valueAt(s1))])
        curve = NurbsCurve2D.line(ends[0], ends[1], s0, s1)
    elif kind in ("Circle", "Ellipse"):
        rx, ry = ((geom.Radius, geom.Radius) if kind == "Circle"
                  else (geom.MajorRadius, geom.MinorRadius))
        curve = ConicArc2D(image([_xyz(geom.Center)])[0], L @ np.array(_xyz(geom.XAxis)),
                           L @ np.array(_xyz(geom.YAxis)), rx, ry, s0, s1)
    elif kind in ("BSplineCurve", "BezierCurve"):
        g = geom.copy()
        if kind == "BSplineCurve" and g.isPeriodic():
            g.setNotPeriodic()
        poles = image([_xyz(q) for q in g.getPoles()])
        knots = (list(g.KnotSequence) if kind == "BSplineCurve"
                 else [0.0] * (g.Degree + 1) + [1.0] * (g.Degree + 1))
        curve = NurbsCurve2D(g.Degree, knots, poles, list(g.getWeights()), s0, s1)
    s = np.linspace(s0, s1, 5)
    ref = image([_xyz(edge.valueAt(float(x))) for x in s])
    size = max(1.0, float(np.abs(ref).max()))
    if curve is None or np.abs(curve.value(s) - ref).max() > 1e-12 * size:
        def value(t):
            return image([_xyz(edge.valueAt(float(x))) for x in t])

        def derivative(t):
            return np.array([_xyz(edge.derivative1At(float(x))) for x in t]).reshape(-1, 3) @ L.T
        curve = FunctionCurve2D(value, derivative, s0, s1)
    return curve


def plane_pcurve(edge, pcurve, frame):
    """The p-curve of an edge of a planar face, checked against the edge's 3-D curve.

    pcurve: face.curveOnSurface(edge) ((geom2d, s0, s1) or None). Returns (curve, note):
    the stored p-curve and None when S(p-curve) stays within the edge's tolerance of the
    3-D curve at PLANE_CHECK_SAMPLES parameters; otherwise, when the 3-D curve lies in the
    plane within that tolerance, its exact image (:func:`plane_image`) and a note. A
    missing p-curve whose edge leaves the plane raises InputError; a wrong one is kept.
    """
    stored = None if pcurve is None else curve_from_geom2d(*pcurve)
    if edge.Degenerated:
        if stored is None:
            raise InputError("degenerated edge without a p-curve on a plane")
        return stored, None
    o, X, Y = frame
    tol = max(float(edge.Tolerance), PRECISION_CONFUSION)
    s0, s1 = (float(x) for x in edge.ParameterRange)
    try:
        pts = np.array([_xyz(edge.valueAt(float(x)))
                        for x in np.linspace(s0, s1, PLANE_CHECK_SAMPLES)])
        kind = type(edge.Curve).__name__
    except Exception:  # OCC raises its own types: no 3-D curve to compare with
        if stored is None:
            raise InputError("face edge has neither a p-curve nor a 3-D curve") from None
        return stored, None
    deviation = np.inf
    if stored is not None:
        uv = stored.value(np.linspace(stored.s0, stored.s1, PLANE_CHECK_SAMPLES))
        on_plane = o + uv[:, :1] * X + uv[:, 1:] * Y
        deviation = float(np.linalg.norm(on_plane - pts, axis=1).max())
        if deviation <= tol:
            return stored, None
    normal = np.cross(X, Y)
    off_plane = float(np.abs((pts - o) @ normal).max())
    if off_plane > tol:
        if stored is None:
            raise InputError("face edge has no p-curve and its 3-D curve leaves the face's plane "
                             "by %.3g (tolerance %.3g)" % (off_plane, tol))
        return stored, None
    what = ("missing p-curve" if stored is None else
            "p-curve %.3g off its 3-D curve (tolerance %.3g)" % (deviation, tol))
    return plane_image(edge, frame), "plane: %s replaced by the image of the 3-D %s" % (
        what, kind)


def close_gaps(evaluator, end_vertices, vertices, error):
    """Straight parameter segments closing the trim loops at their open ends, exactly.

    evaluator: the face's SurfaceEvaluator; end_vertices: per p-curve the indices into
    vertices of the topological vertices at its start and end (plain_records.edge_vertices);
    vertices: (point (x, y, z), tolerance) of each; error: the :class:`OpenTrimLoops` of the
    p-curves. The open ends are grouped by the topological vertex of their edge (the edge's
    first vertex for a p-curve's start, its last for its end) and paired, nearest first,
    within a vertex. The segment from end p to end q is accepted when its image
    g(t) = S(p + t (q - p)) stays in the vertex's tolerance ball: max |g(t_i) - V| over
    GAP_SAMPLES points plus the chord bound h^2/8 max |g''| (h the sample spacing) is at
    most the vertex tolerance. Exactness: a BRep vertex is the ball |x - V| <= tol_V, and
    the two edges meet there by the shape's own topology; the segment adds no boundary
    outside that ball, so the closed domain is the face the BRep defines, ambiguous only
    inside the ball (area at most about pi tol_V^2 per gap). On a collapsed side of the
    surface (S constant along the segment: a pole, a cone apex) g is the vertex point itself.
    Returns (segments, notes); raises InputError (the error's message and the reason)
    when some open end has no such closure.
    """
    def fail(reason):
        raise InputError("%s; no exact closure: %s" % (error, reason)) from error

    ends = error.ends
    groups = {}  # vertex index -> [end indices], in order of first appearance
    for i in (int(k) for k in error.open_ends):
        groups.setdefault(end_vertices[i // 2][i % 2], []).append(i)
    segments, notes = [], []
    t = np.linspace(0.0, 1.0, GAP_SAMPLES)
    h = t[1] - t[0]
    for vid, idx in groups.items():
        point, vertex_tol = vertices[vid]
        V = np.array(point, dtype=float)
        tol = max(float(vertex_tol), PRECISION_CONFUSION)
        if len(idx) % 2:
            fail("%d open p-curve end(s) at the vertex (%.6g, %.6g, %.6g), none of another "
                 "edge there to join" % ((len(idx),) + tuple(V)))
        idx = list(idx)
        while idx:
            pairs = [(float(np.linalg.norm(ends[a] - ends[b])), a, b)
                     for j, a in enumerate(idx) for b in idx[j + 1:]]
            _, a, b = min(pairs)
            idx.remove(a), idx.remove(b)
            p, q = ends[a], ends[b]
            d = q - p
            uv = p + t[:, None] * d
            S, _, _, Suu, Suv, Svv = evaluator.derivatives(uv[:, 0], uv[:, 1])
            g2 = d[0] ** 2 * Suu + 2.0 * d[0] * d[1] * Suv + d[1] ** 2 * Svv
            dev = float(np.linalg.norm(S - V, axis=1).max())
            bound = dev + h * h / 8.0 * float(np.linalg.norm(g2, axis=1).max())
            if not bound <= tol:
                fail("the parameter segment from (%.6g, %.6g) to (%.6g, %.6g) leaves the vertex "
                     "(%.6g, %.6g, %.6g) by %.3g, more than its tolerance %.3g"
                     % (tuple(p) + tuple(q) + tuple(V) + (bound, tol)))
            segments.append(NurbsCurve2D.line(p, q))
            kind = "collapsed side" if bound <= PRECISION_CONFUSION else "gap"
            notes.append("%s closed at vertex (%.6g, %.6g, %.6g): parameter segment (%.6g, %.6g)-"
                         "(%.6g, %.6g), 3-D deviation %.3g <= vertex tolerance %.3g"
                         % ((kind,) + tuple(V) + tuple(p) + tuple(q) + (bound, tol)))
    return segments, notes


#: Newton steps of the inversion u(s) = u of a monotone piece before bisection takes over.
NEWTON_STEPS = 6


def _invert_monotone(curve, u, a, b, fa, fb, xtol):
    """Parameters s (m,) with U(s) = u (m,) of curve (its first coordinate U monotone on
    each bracket [a, b], fa = U(a) - u and fb = U(b) - u of opposite signs). Curves without
    an exact derivative go to solve_bracketed directly.

    Safeguarded Newton: started by regula falsi, each step evaluates U and U' in one call;
    a step that leaves the current bracket is replaced by bisection, and the bracket shrinks
    with the sign of U - u. Brackets still open after NEWTON_STEPS go to solve_bracketed.
    From samples a few per knot span apart, Newton reaches the tolerance in about three steps
    (quadratic convergence), against about eight for the derivative-free method."""
    if not curve.exact_derivative:
        return solve_bracketed(lambda y, k: curve.value(y)[:, 0] - u[k], a, b, fa, fb, xtol)
    a, b = np.array(a, dtype=float), np.array(b, dtype=float)
    fa, fb = np.array(fa, dtype=float), np.array(fb, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        x = np.where(fb != fa, a - fa * (b - a) / (fb - fa), 0.5 * (a + b))
    x = np.where((x > np.minimum(a, b)) & (x < np.maximum(a, b)), x, 0.5 * (a + b))
    done = np.zeros(u.size, bool)
    for _ in range(NEWTON_STEPS):
        i = np.nonzero(~done)[0]
        if i.size == 0:
            break
        C, dC = curve.value_and_derivative(x[i])
        g, dg = C[:, 0] - u[i], dC[:, 0]
        same_a = np.sign(g) == np.sign(fa[i])
        a[i] = np.where(same_a, x[i], a[i])
        fa[i] = np.where(same_a, g, fa[i])
        b[i] = np.where(same_a, b[i], x[i])
        fb[i] = np.where(same_a, fb[i], g)
        with np.errstate(divide="ignore", invalid="ignore"):
            xn = x[i] - g / dg
        lo, hi = np.minimum(a[i], b[i]), np.maximum(a[i], b[i])
        inside = np.isfinite(xn) & (xn > lo) & (xn < hi)
        xn = np.where(inside, xn, 0.5 * (a[i] + b[i]))
        done[i] = (g == 0.0) | (np.abs(xn - x[i]) <= xtol)
        x[i] = np.where(g == 0.0, x[i], xn)
    i = np.nonzero(~done)[0]
    if i.size:
        ui = u[i]
        x[i] = solve_bracketed(lambda y, k: curve.value(y)[:, 0] - ui[k], a[i], b[i], fa[i], fb[i], xtol)
    return x


# ---------------------------------------------------------------------------------------------
# the domain


class TrimmedDomain:
    """The trimmed parameter domain of a face, from its trim curves (see module docstring).

    Attributes: curves (list of Curve2D), repairs (list of str: exact repairs made by
    :meth:`from_face`, empty when none), u_range, v_range (2-tuples), is_rectangle (True
    when Omega is its bounding rectangle, the untrimmed natural face), slabs (list of
    (u0, u1, lo_pieces (k,) int, hi_pieces (k,) int)), and per monotone piece the arrays
    piece_u_lo, piece_u_hi (snapped u range), piece_const_v (v of a horizontal piece, else
    NaN), piece_turns (k, 2) bool (vertical tangent at the u_lo, u_hi end), turning_u (u of
    all such ends).
    """

    def __init__(self, curves, repairs=()):
        self.curves = list(curves)
        self.repairs = list(repairs)
        if not self.curves:
            raise InputError("trimmed domain: no trim curves")
        self._build_samples()
        self._build_pieces()
        self._build_slabs()

    # -- constructors -------------------------------------------------------------------------

    @classmethod
    def from_curves(cls, curves):
        """Domain enclosed (even-odd) by closed loops made of the given Curve2D objects."""
        return cls(curves)

    @classmethod
    def rectangle(cls, u0, u1, v0, v1):
        """The rectangle [u0, u1] x [v0, v1]."""
        pts = [(u0, v0), (u1, v0), (u1, v1), (u0, v1)]
        return cls.polygon(pts)

    @classmethod
    def polygon(cls, points):
        """The closed polygon through points (k, 2) (straight edges)."""
        pts = np.asarray(points, dtype=float)
        return cls([NurbsCurve2D.line(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))])

    @classmethod
    def disc(cls, center, radius):
        """The disc of given radius about center."""
        return cls([ConicArc2D.circle(center, radius)])

    @classmethod
    def annulus(cls, center, r_inner, r_outer):
        """The annulus r_inner <= |(u, v) - center| <= r_outer."""
        return cls([ConicArc2D.circle(center, r_outer), ConicArc2D.circle(center, r_inner, True)])

    @classmethod
    def from_face(cls, face):
        """Domain of a Part.Face from the p-curves of all edges of all its wires.

        Wire children are iterated (not ``Wire.Edges``, which lists a seam edge once), so a
        seam contributes the p-curves of both its occurrences. Exact repairs, each noted
        in ``repairs``: on a plane, a missing p-curve or one off its edge's 3-D curve is
        replaced by the 3-D curve's exact image (:func:`plane_pcurve`); loops left open at
        a vertex are closed by parameter segments that stay in the vertex's tolerance ball
        (:func:`close_gaps`; a collapsed side of the surface is such a segment). Raises
        InputError when an edge has no p-curve (off a plane) or the loops stay open.
        """
        frame = plane_frame(face)
        curves, edges, repairs = [], [], []
        for edge, pc in face_pcurves(face):
            if frame is not None:
                curve, note = plane_pcurve(edge, pc, frame)
                if note:
                    repairs.append("edge %d: %s" % (len(curves), note))
            elif pc is None:
                raise InputError("face edge has no curve in the face's parameter space "
                                 "(p-curve); repair the shape (e.g. Part's shape fixer)")
            else:
                curve = curve_from_geom2d(*pc)
            curves.append(curve)
            edges.append(edge)
        try:
            domain = cls(curves, repairs)
        except OpenTrimLoops as exc:
            from .surface_eval import SurfaceEvaluator
            segments, notes = close_gaps(SurfaceEvaluator.for_face(face), *edge_vertices(edges), exc)
            domain = cls(curves + segments, repairs + notes)
        domain.face_parameter_range = tuple(face.ParameterRange)
        return domain

    @classmethod
    def from_record(cls, rec, evaluator):
        """Domain of a face from plain_records.face_record's p-curves and edge vertices, the
        same as from_face gives for that face (evaluator: its SurfaceEvaluator, for closing
        loop gaps); None when a p-curve's conversion fails its check (from_face then
        evaluates it through OpenCascade)."""
        curves = [curve_from_record(r) for r in rec["pcurves"]]
        if any(c is None for c in curves):
            return None
        try:
            domain = cls(curves)
        except OpenTrimLoops as exc:
            segments, notes = close_gaps(evaluator, rec["end_vertices"], rec["vertices"], exc)
            domain = cls(curves + segments, notes)
        domain.face_parameter_range = tuple(rec["parameter_range"])
        return domain

    # -- construction -------------------------------------------------------------------------

    def _build_samples(self):
        self._s, self._uv, self._d = [], [], []
        for c in self.curves:
            s = np.unique(np.concatenate((c.sample_params(), c.breaks, [c.s0, c.s1])))
            s = s[(s >= c.s0) & (s <= c.s1)]
            self._s.append(s)
            self._uv.append(c.value(s))
            self._d.append(c.derivative(s))
        allpts = np.concatenate(self._uv)
        lo, hi = allpts.min(0), allpts.max(0)
        self._scale = max(float(np.max(hi - lo)), 1e-300)
        ends = np.array([[uv[0], uv[-1]] for uv in self._uv]).reshape(-1, 2)  # (2n, 2)
        n = len(self.curves)
        dist = np.linalg.norm(ends[:, None, :] - ends[None, :, :], axis=2)
        np.fill_diagonal(dist, np.inf)
        own = np.arange(2 * n) ^ 1  # the other end of the same curve
        closed_own = dist[np.arange(2 * n), own] <= CLOSURE_RTOL * self._scale
        dist[np.arange(2 * n), own] = np.where(closed_own, dist[np.arange(2 * n), own], np.inf)
        partner = dist.argmin(1)
        gap = dist[np.arange(2 * n), partner]
        if np.any(gap > CLOSURE_RTOL * self._scale):
            i = int(np.argmax(gap))
            raise OpenTrimLoops("trim loops are not closed: the end (%.6g, %.6g) of p-curve %d has "
                                "no other curve end within %.3g in parameter space"
                                % (ends[i, 0], ends[i, 1], i // 2, CLOSURE_RTOL * self._scale),
                                ends, np.nonzero(gap > CLOSURE_RTOL * self._scale)[0],
                                CLOSURE_RTOL * self._scale)
        gap_u = np.abs(ends[:, 0] - ends[partner, 0])
        self.snap_tol = max(SNAP_RTOL * self._scale, 2.0 * float(gap_u.max()))

    def _extrema(self, ci, comp):
        """Parameters of curve ci where component comp has a local extremum: where its
        derivative changes sign between consecutive nonzero samples, refined on the
        derivative when the samples are adjacent, else the first sample of the exactly
        zero run between them (a sample on the extremum)."""
        c, s, d = self.curves[ci], self._s[ci], self._d[ci][:, comp]
        nz = np.nonzero(d)[0]
        flip = np.nonzero(np.sign(d[nz[:-1]]) * np.sign(d[nz[1:]]) < 0)[0]
        a, b = nz[flip], nz[flip + 1]
        on_sample = s[a[b > a + 1] + 1]
        k = a[b == a + 1]
        if k.size == 0:
            return on_sample
        xtol = 4e-16 * (abs(c.s0) + abs(c.s1)) + 1e-15 * (c.s1 - c.s0)
        return np.concatenate((on_sample, solve_bracketed(
            lambda x, i: c.derivative(x)[:, comp], s[k], s[k + 1], d[k], d[k + 1], xtol)))

    def _build_pieces(self):
        pc, pa, pb = [], [], []
        vmin, vmax = np.inf, -np.inf
        for ci, c in enumerate(self.curves):
            cuts = np.unique(np.concatenate(([c.s0], self._extrema(ci, 0), c.breaks, [c.s1])))
            for a, b in zip(cuts[:-1], cuts[1:]):
                if b > a:
                    pc.append(ci), pa.append(a), pb.append(b)
            vext = self._extrema(ci, 1)
            vv = np.concatenate((self._uv[ci][:, 1], c.value(vext)[:, 1] if vext.size else []))
            vmin, vmax = min(vmin, vv.min()), max(vmax, vv.max())
        pc, pa, pb = np.array(pc, int), np.array(pa), np.array(pb)
        ua = np.array([self.curves[c].value([a])[0, 0] for c, a in zip(pc, pa)])
        ub = np.array([self.curves[c].value([b])[0, 0] for c, b in zip(pc, pb)])
        # snap end values of u that are closer than the loops' closure gap
        allu = np.concatenate((ua, ub))
        order = np.argsort(allu)
        su = allu[order]
        cluster = np.concatenate(([0], np.cumsum(np.diff(su) > self.snap_tol)))
        rep = np.array([np.median(su[cluster == k]) for k in range(cluster[-1] + 1)])
        snapped = np.empty_like(allu)
        snapped[order] = rep[cluster]
        sa, sb = snapped[:len(ua)], snapped[len(ua):]
        keep = sa != sb  # vertical pieces never cross a line u = const transversally
        self.breakpoints = rep
        self.u_range = (float(rep[0]), float(rep[-1]))
        self.v_range = (float(vmin), float(vmax))
        self.piece_curve = pc[keep]
        rev = (ub < ua)[keep]
        self.piece_s_lo = np.where(rev, pb[keep], pa[keep])  # parameter at the low-u end
        self.piece_s_hi = np.where(rev, pa[keep], pb[keep])
        self.piece_u_lo = np.minimum(sa, sb)[keep]
        self.piece_u_hi = np.maximum(sa, sb)[keep]
        self.piece_const_v = np.full(self.piece_curve.size, np.nan)
        self._piece_s, self._piece_u = [], []
        for k, ci in enumerate(self.piece_curve):
            c = self.curves[ci]
            lo, hi = sorted((self.piece_s_lo[k], self.piece_s_hi[k]))
            s = self._s[ci]
            s = np.concatenate(([lo], s[(s > lo) & (s < hi)], [hi]))
            u = c.value(s)[:, 0]
            if self.piece_s_hi[k] < self.piece_s_lo[k]:
                s, u = s[::-1], u[::-1]
            self._piece_s.append(s)
            self._piece_u.append(np.maximum.accumulate(u))  # monotone up to rounding
            if c.horizontal_v is not None:
                self.piece_const_v[k] = c.horizontal_v
        # ends where a piece has a vertical tangent (a strip width there goes like sqrt)
        self.piece_turns = np.zeros((self.piece_curve.size, 2), bool)  # at u_lo, at u_hi
        for k, ci in enumerate(self.piece_curve):
            d = self.curves[ci].derivative([self.piece_s_lo[k], self.piece_s_hi[k]])
            self.piece_turns[k] = np.abs(d[:, 0]) <= 1e-8 * np.maximum(np.hypot(d[:, 0], d[:, 1]),
                                                                       1e-300)
        self.turning_u = np.unique(np.concatenate((self.piece_u_lo[self.piece_turns[:, 0]],
                                                   self.piece_u_hi[self.piece_turns[:, 1]])))

    def _build_slabs(self):
        self.slabs = []
        bp = self.breakpoints
        rect = True
        for u0, u1 in zip(bp[:-1], bp[1:]):
            um = 0.5 * (u0 + u1)
            active = np.nonzero((self.piece_u_lo <= um) & (self.piece_u_hi > um))[0]
            if active.size % 2:
                raise InputError("trim loops cross a parameter line u = %.6g an odd number of "
                                 "times; the face's p-curves do not form closed loops" % um)
            v = np.array([self.piece_v(k, np.array([um]))[0] for k in active])
            order = active[np.argsort(v, kind="stable")]
            lo, hi = order[0::2], order[1::2]
            self.slabs.append((float(u0), float(u1), lo, hi))
            cv = self.piece_const_v
            rect &= (lo.size == 1 and cv[lo[0]] == self.v_range[0] and cv[hi[0]] == self.v_range[1])
        self.is_rectangle = bool(rect)

    # -- queries ------------------------------------------------------------------------------

    def piece_v(self, k, u):
        """v (m,) of monotone piece k on the lines u (m,) (clamped to the piece's u range)."""
        u = np.asarray(u, dtype=float).ravel()
        if not np.isnan(self.piece_const_v[k]):
            return np.full(u.size, self.piece_const_v[k])
        c = self.curves[self.piece_curve[k]]
        s, us = self._piece_s[k], self._piece_u[k]
        j = np.clip(np.searchsorted(us, u, side="right") - 1, 0, us.size - 2)
        uq = np.clip(u, us[0], us[-1])
        fa, fb = us[j] - uq, us[j + 1] - uq
        sq = np.empty(u.size)
        at_a, at_b = fa >= 0.0, fb <= 0.0
        sq[at_a] = s[j[at_a]]
        sq[at_b & ~at_a] = s[j[at_b & ~at_a] + 1]
        mid = ~at_a & ~at_b
        if mid.any():
            xtol = 4e-16 * (abs(s[0]) + abs(s[-1])) + 1e-15 * abs(s[-1] - s[0])
            sq[mid] = _invert_monotone(c, uq[mid], s[j[mid]], s[j[mid] + 1], fa[mid], fb[mid], xtol)
        return c.value(sq)[:, 1]

    def v_intervals(self, u):
        """Inside intervals of the lines u = const, for u (m,) float.

        Returns (index, lo, hi): flat arrays, interval k is v in [lo[k], hi[k]] on the line
        u[index[k]]; sorted by index, then by v. Lines outside u_range have none.
        """
        u = np.asarray(u, dtype=float).ravel()
        if self.is_rectangle:
            idx = np.nonzero((u >= self.u_range[0]) & (u <= self.u_range[1]))[0]
            return (idx, np.full(idx.size, self.v_range[0]), np.full(idx.size, self.v_range[1]))
        ii, vv = [], []
        for k in range(self.piece_curve.size):
            sel = np.nonzero((u >= self.piece_u_lo[k]) & (u < self.piece_u_hi[k]))[0]
            if sel.size:
                ii.append(sel)
                vv.append(self.piece_v(k, u[sel]))
        if not ii:
            return np.empty(0, int), np.empty(0), np.empty(0)
        ii, vv = np.concatenate(ii), np.concatenate(vv)
        order = np.lexsort((vv, ii))
        ii, vv = ii[order], vv[order]
        if np.any(np.bincount(ii, minlength=u.size) % 2):
            raise InputError("trim loops cross a parameter line u = const an odd number of "
                             "times; the face's p-curves do not form closed loops")
        return ii[0::2], vv[0::2], vv[1::2]

    def u_breakpoints(self):
        """u values (k,) where the strip structure changes: vertices, u-extrema, corners."""
        return self.breakpoints.copy()

    def v_line_crossings(self, v_values):
        """u values (k,) where the trim curves cross the lines v = v_values (sorted, unique)."""
        v_values = np.asarray(v_values, dtype=float).ravel()
        out = []
        for k, ci in enumerate(self.piece_curve):
            if v_values.size == 0 or not np.isnan(self.piece_const_v[k]):
                continue
            c, s = self.curves[ci], self._piece_s[k]
            g = c.value(s)[:, 1][:, None] - v_values[None, :]  # (ns, nv)
            j, m = np.nonzero((np.sign(g[:-1]) * np.sign(g[1:]) < 0))
            exact = np.nonzero(g == 0.0)
            out.append(c.value(s[exact[0]])[:, 0])
            if j.size:
                vm = v_values[m]
                xtol = 4e-16 * (abs(s[0]) + abs(s[-1])) + 1e-15 * abs(s[-1] - s[0])
                r = solve_bracketed(lambda x, i: c.value(x)[:, 1] - vm[i], s[j], s[j + 1],
                                    g[j, m], g[j + 1, m], xtol)
                out.append(c.value(r)[:, 0])
        return np.unique(np.concatenate(out)) if out else np.empty(0)
