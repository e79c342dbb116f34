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

Faces read from files may need exact repairs, which TrimmedDomain.from_face makes
(trim_repair) and lists in ``repairs``; loops that no exact repair closes are an
InputError, and the face's integration then falls back to polygon_domain, a domain of
straight segments through the projected points of its 3-D edges.
"""
import copy
import functools
import pickle

import numpy as np

from ...core.errors import InputError
from ..reading.occ_records import edge_vertices, face_pcurves
from .pcurves import ConicArc2D, NurbsCurve2D, curve_from_geom2d, curve_from_record
from ..cubature.roots import solve_bracketed
from .surface_eval import SurfaceEvaluator
from .trim_repair import close_gaps, plane_frame, plane_pcurve

#: Relative parameter tolerance below which two breakpoint values are the same.
SNAP_RTOL = 1e-11
#: Loops whose end points are further apart than this fraction of the domain's size are open.
CLOSURE_RTOL = 1e-5
#: Deflection of the 3-D edge polygons of a fallback domain, relative to the face's size.
POLYGON_DEFLECTION = 1e-6


class EmptyDomain(Exception):
    """A face whose trimmed domain has no extent in u or v: it carries no area."""


class OpenTrimLoops(InputError):
    """The trim curves do not form closed loops.

    ends (2n, 2) float: start and end point of each curve (curve i has ends 2i, 2i + 1);
    open_ends (k,) int: indices of the ends with no other end within ``tolerance``.
    """

    def __init__(self, message, ends, open_ends, tolerance):
        super().__init__(message)
        self.ends, self.open_ends, self.tolerance = ends, open_ends, tolerance


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


class TrimmedDomain:
    """The trimmed parameter domain of a face, from its trim curves (see module docstring).

    Attributes: curves (list of Curve2D), repairs (list of str: exact repairs made by
    :meth:`from_face`, empty when none), fallback (why the domain is polygon_domain's, from
    the 3-D edges; None for a domain of the p-curves), u_range, v_range (2-tuples), is_rectangle (True
    when Omega is its bounding rectangle, the untrimmed natural face), slabs (list of
    (u0, u1, lo_pieces (k,) int, hi_pieces (k,) int)), and per monotone piece the arrays
    piece_u_lo, piece_u_hi (snapped u range), piece_const_v (v of a horizontal piece, else
    NaN), piece_turns (k, 2) bool (vertical tangent at the u_lo, u_hi end), turning_u (u of
    all such ends).
    """

    def __init__(self, curves, repairs=(), fallback=None):
        self.curves = list(curves)
        self.repairs = list(repairs)
        self.fallback = fallback
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
        """The rectangle [u0, u1] x [v0, v1], one object for each (the integrations only read
        their domains, and the graded neighbourhoods' audits integrate the same few
        rectangles many times: each takes milliseconds to build)."""
        return _rectangle(cls, float(u0), float(u1), float(v0), float(v1))

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
            segments, notes = close_gaps(SurfaceEvaluator.for_face(face), *edge_vertices(edges), exc)
            domain = cls(curves + segments, repairs + notes)
        domain.face_parameter_range = tuple(face.ParameterRange)
        return domain

    @classmethod
    def from_record(cls, rec, evaluator):
        """Domain of a face from the p-curves and edge vertices of its occ_records.FaceData, the
        same as from_face gives for that face (evaluator: its SurfaceEvaluator, for closing
        loop gaps); None when a p-curve's conversion fails its check (from_face then
        evaluates it through OpenCascade). Faces whose p-curve records are equal share one
        domain built from them (_closed_loops_of), each with its own face_parameter_range."""
        key = (cls, pickle.dumps(rec.pcurves, protocol=4))
        domain = _closed_loops_of(key)
        if domain is None:
            curves = [curve_from_record(r) for r in rec.pcurves]
            if any(c is None for c in curves):
                return None
            try:
                domain = cls(curves)
            except OpenTrimLoops as exc:  # closed through the face's own surface
                segments, notes = close_gaps(evaluator, rec.end_vertices, rec.vertices, exc)
                domain = cls(curves + segments, notes)
            else:
                _CLOSED_LOOPS[key] = domain
                while len(_CLOSED_LOOPS) > RECORD_DOMAINS_KEPT:
                    _CLOSED_LOOPS.pop(next(iter(_CLOSED_LOOPS)))
        domain = copy.copy(domain)  # shares the built arrays, which nothing changes
        domain.face_parameter_range = tuple(rec.parameter_range)
        return domain

    # -- construction -------------------------------------------------------------------------

    def _build_samples(self):
        self._s, self._uv, self._d = [], [], []
        for c in self.curves:
            s = np.unique(np.concatenate((c.sample_params(), c.breaks, [c.s0, c.s1])))
            s = s[(s >= c.s0) & (s <= c.s1)]
            uv, d = c.value_and_derivative(s)
            self._s.append(s)
            self._uv.append(uv)
            self._d.append(d)
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
            # the curve's samples, when the piece is the whole curve: their values as made
            u = (self._uv[ci] if np.array_equal(s, self._s[ci]) else c.value(s))[:, 0]
            if self.piece_s_hi[k] < self.piece_s_lo[k]:
                s, u = s[::-1], u[::-1]
            self._piece_s.append(s)
            self._piece_u.append(np.maximum.accumulate(u))  # monotone up to rounding
            if c.horizontal_v is not None:
                self.piece_const_v[k] = c.horizontal_v
        # ends where a piece has a vertical tangent (a strip width there goes like sqrt)
        self.piece_turns = np.zeros((self.piece_curve.size, 2), bool)  # at u_lo, at u_hi
        for k, ci in enumerate(self.piece_curve):
            ends = np.array([self.piece_s_lo[k], self.piece_s_hi[k]])
            d = self._d[ci] if np.array_equal(ends, self._s[ci]) else self.curves[ci].derivative(ends)
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


def polygon_domain(face, reason=None):
    """Fallback trimmed domain when the face's p-curves do not form closed loops (reason: why,
    its fallback attribute): each wire
    discretised in 3-D (deflection POLYGON_DEFLECTION of the face's size), its points
    projected into the face's parameter space, joined by straight lines (closed by
    construction). Exact for straight trims of planes; otherwise an approximation that the
    validity record names."""
    size = max(face.BoundBox.DiagonalLength, 1e-300)
    surf = face.Surface
    curves = []
    for wire in face.Wires:
        pts = wire.discretize(Deflection=POLYGON_DEFLECTION * size)
        uv = np.array([surf.parameter(p) for p in pts], dtype=float)
        if len(uv) > 1 and np.allclose(uv[0], uv[-1]):
            uv = uv[:-1]
        for i in range(len(uv)):
            a, b = uv[i], uv[(i + 1) % len(uv)]
            if np.any(a != b):
                curves.append(NurbsCurve2D.line(a, b))
    return TrimmedDomain(curves, fallback=reason)


#: Domains of closed p-curve loops kept by their records (the faces of a hull's untrimmed
#: patches often share the four sides of one parameter rectangle, [0, 1]^2).
RECORD_DOMAINS_KEPT = 256
_CLOSED_LOOPS = {}


def _closed_loops_of(key):
    """The domain of the class and p-curve records' pickle key, when their loops closed
    without the surface's help (a domain closed through a face's surface is that face's
    own), else None; the most recently used last in the dict (the first are let go)."""
    domain = _CLOSED_LOOPS.pop(key, None)
    if domain is not None:
        _CLOSED_LOOPS[key] = domain
    return domain


@functools.lru_cache(maxsize=256)
def _rectangle(cls, u0, u1, v0, v1):
    return cls.polygon([(u0, v0), (u1, v0), (u1, v1), (u0, v1)])
