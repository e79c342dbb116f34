"""Degenerate parameter points of a face, graded refinement toward them, and the
nested-neighbourhood audit that tells a convergent improper integral (VALID*) from a
non-integrable singularity (SINGULAR) (paper section 4.3 and the public-hull audit of
section 6.2).

A point is degenerate where the area element J = |S_u x S_v| vanishes relative to
max(E, G) (a collapsed pole row, a pole, parallel tangents). Such points sit at patch
corners and sides, so they are looked for on the knot grid and along the domain's sides;
isolated ones inside the knot spans (pinch points) are found by Newton's method on
S_u x S_v = 0 (geometry.degenerate_points) and integrated by pinch_points.
"""
from dataclasses import dataclass, field

import numpy as np

from ..cubature.cells import grid_points
from ..cubature import integrate
from ..geometry.degenerate_points import isolated_zeros
from ..geometry.trimmed_domain import TrimmedDomain

#: J / max(E, G) below this is degenerate.
DEGENERATE_RTOL = 1e-8
#: Points closer than this fraction of the parameter ranges to a knot-grid node or a collapsed
#: side are that node's or side's.
NODE_RTOL = 1e-9
#: Samples per knot span along each side of the parameter rectangle.
SIDE_SAMPLES = 8
#: Nested neighbourhoods of the audit: r0 * 2^-k, k = 0..AUDIT_LEVELS-1 (down to about
#: 1e-4 r0: a curvature peak confined to a small core shows its power law only there); the
#: first AUDIT_FIRST_LEVELS of them decide a bounded or convergent case.
AUDIT_LEVELS = 14
AUDIT_FIRST_LEVELS = 6
#: The first neighbourhoods decide a convergent case only with a decay power above this
#: (well clear of CONVERGENT_POWER); otherwise the innermost ones decide.
FIRST_CLEAR_POWER = 0.5
#: The decay power is fitted on the innermost neighbourhoods, from this level on.
AUDIT_FIT_FROM = 7
#: Fitted decay power of the excluded |K| integral above which the integral converges.
CONVERGENT_POWER = 0.25
#: Decay power of the excluded |K| integral from which K is taken as bounded (E ~ r^2 when
#: K is bounded; E ~ r^(2 - a) for |K| ~ r^-a).
BOUNDED_POWER = 1.9
#: Growth of max |K| over the audit neighbourhoods above which K is unbounded there.
UNBOUNDED_GROWTH = 10.0


#: |K| at or below this multiple of the machine epsilon times k1^2 + k2^2 is zero to the
#: rounding of the principal curvatures (KZeroToRounding).
K_ROUNDING = 16.0


#: A knot-grid node whose |K| J exceeds this multiple of the face's mean is a hot spot.
HOT_SPOT_FACTOR = 100.0


@dataclass
class DegenerateSet:
    """Degenerate points (u, v) of the knot grid, collapsed sides ('u0', 'u1', 'v0', 'v1'),
    hot spots (regular knot-grid nodes where |K| J peaks far above the face's mean:
    near-degenerate corners) and pinch points (isolated degenerate points inside the knot
    spans) of a face. The points of the knot grid and the hot spots get graded refinement,
    the pinch points the whitened polar rule (pinch_points); degenerate points are audited."""

    points: list = field(default_factory=list)
    sides: list = field(default_factory=list)
    hot_spots: list = field(default_factory=list)
    #: knot-grid nodes where the adaptive refinement stalled (points_from_refinement):
    #: graded and audited like degenerate points
    stalled: list = field(default_factory=list)
    #: pinch points: isolated degenerate points inside the knot spans
    #: (degenerate_points.isolated_zeros), integrated by pinch_points and audited
    interior: list = field(default_factory=list)

    def __bool__(self):
        return bool(self.points or self.sides or self.hot_spots or self.stalled or self.interior)

    @property
    def graded_points(self):
        return list(self.points) + list(self.hot_spots) + list(self.stalled)

    @property
    def audited_points(self):
        """Degenerate points and stalled nodes (a hot spot is a regular node, J > 0: its
        curvature is bounded, and grading it is for speed alone)."""
        return list(self.points) + list(self.stalled) + list(self.interior)

    def to_dict(self):
        return {"points": [[float(u), float(v)] for u, v in self.points], "collapsed_sides": list(self.sides),
                "hot_spots": [[float(u), float(v)] for u, v in self.hot_spots],
                "refinement_stalled": [[float(u), float(v)] for u, v in self.stalled],
                "inside_spans": [[float(u), float(v)] for u, v in self.interior]}


def _grid_values(lo, hi, breaks):
    b = np.asarray(breaks, dtype=float)
    return np.unique(np.concatenate([[lo, hi], b[(b > lo) & (b < hi)]]))


def find_degenerate(face_field, domain, u_breaks, v_breaks):
    """DegenerateSet of a face: knot-grid corners and side samples where J vanishes."""
    u0, u1 = domain.u_range
    v0, v1 = domain.v_range
    gu = _grid_values(u0, u1, u_breaks)
    gv = _grid_values(v0, v1, v_breaks)

    out = DegenerateSet()
    # Sides: collapsed when every sample along the side is degenerate; the samples of the
    # four sides and the knot-grid nodes in one evaluation
    t = np.linspace(0.0, 1.0, SIDE_SAMPLES + 1)
    su = np.unique(np.concatenate([a + (b - a) * t for a, b in zip(gu[:-1], gu[1:])]))
    sv = np.unique(np.concatenate([a + (b - a) * t for a, b in zip(gv[:-1], gv[1:])]))
    sides = {"v0": (su, np.full_like(su, v0)), "v1": (su, np.full_like(su, v1)),
             "u0": (np.full_like(sv, u0), sv), "u1": (np.full_like(sv, u1), sv)}
    U, V = np.meshgrid(gu, gv, indexing="ij")
    U, V = U.ravel(), V.ravel()
    _, Su, Sv = face_field.evaluator.first_derivatives(np.concatenate([uu for uu, _ in sides.values()] + [U]),
                                                       np.concatenate([vv for _, vv in sides.values()] + [V]))
    J = np.linalg.norm(np.cross(Su, Sv), axis=1)
    degenerate = ~(J > DEGENERATE_RTOL * np.maximum((Su * Su).sum(1), (Sv * Sv).sum(1)))
    start = 0
    for name, (uu, _) in sides.items():
        if degenerate[start:start + uu.size].all():
            out.sides.append(name)
        start += uu.size
    # Isolated points at knot-grid nodes not on a collapsed side.
    bad = degenerate[start:]
    on_side = np.zeros_like(bad)
    for name in out.sides:
        on_side |= {"v0": V == v0, "v1": V == v1, "u0": U == u0, "u1": U == u1}[name]
    inside = _inside_or_on(domain, U, V)
    for u, v in zip(U[bad & ~on_side & inside], V[bad & ~on_side & inside]):
        out.points.append((float(u), float(v)))
    out.interior = _off_grid_points(face_field, domain, gu, gv, out)
    # Hot spots: regular nodes where the integrand |K| J towers over the face's mean.
    ok = ~bad & ~on_side & inside
    if ok.any():
        g = (np.arange(16) + 0.5) / 16
        mu, mv = np.meshgrid(u0 + (u1 - u0) * g, v0 + (v1 - v0) * g, indexing="ij")
        f = face_field(np.concatenate((mu.ravel(), U[ok])), np.concatenate((mv.ravel(), V[ok])))
        KJ = np.where(f["regular"], np.abs(f["K"]) * f["J"], np.nan)
        mean = np.nanmean(KJ[:mu.size])
        q = np.nan_to_num(KJ[mu.size:], nan=0.0)
        if np.isfinite(mean) and mean > 0:
            for u, v in zip(U[ok][q > HOT_SPOT_FACTOR * mean], V[ok][q > HOT_SPOT_FACTOR * mean]):
                out.hot_spots.append((float(u), float(v)))
    return out


def _off_grid_points(face_field, domain, gu, gv, found):
    """Isolated degenerate points inside the knot spans or on their sides
    (degenerate_points.isolated_zeros), inside the domain, other than the knot-grid nodes
    and the collapsed sides of found (DegenerateSet). A surface evaluated point by point is
    not searched."""
    if not face_field.evaluator.vectorised:
        return []
    pts = isolated_zeros(face_field.evaluator, gu, gv, DEGENERATE_RTOL)
    if not pts:
        return []
    (u0, u1), (v0, v1) = domain.u_range, domain.v_range
    tu, tv = NODE_RTOL * (u1 - u0), NODE_RTOL * (v1 - v0)
    sides = {"u0": (0, u0, tu), "u1": (0, u1, tu), "v0": (1, v0, tv), "v1": (1, v1, tv)}
    out = []
    for p in pts:
        at_node = np.abs(gu - p[0]).min() <= tu and np.abs(gv - p[1]).min() <= tv
        on_side = any(abs(p[axis] - x) <= t for axis, x, t in (sides[k] for k in found.sides))
        known = any(abs(p[0] - a) <= tu and abs(p[1] - b) <= tv for a, b in found.points)
        if not (at_node or on_side or known):
            out.append(p)
    if not out:
        return []
    inside = _inside_or_on(domain, np.array([p[0] for p in out]), np.array([p[1] for p in out]))
    return [p for p, ok in zip(out, inside) if ok]


#: A refinement stalled at a knot-grid node when the sample of largest |K| J lies within
#: this many widths of the deepest unconverged cells from the node.
STALL_REACH = 2.0
#: A smooth integrand meets the tolerance within this many quadtree levels below the patches
#: (Gauss-Legendre of order 5 gains about 2^-10 a level); refinement deeper than this at a
#: node is taken as a power-law singularity there.
SMOOTH_DEPTH = 8


def points_from_refinement(results, domain, u_breaks, v_breaks, known=()):
    """Knot-grid nodes (u, v) at which an adaptive integration stalled: the K integrals did
    not converge, and the sample of largest |K| J (QuadratureResult.peak_KJ) lies within
    STALL_REACH widths of the smallest unconverged cell from a node of the knot grid (the
    corners of the domain included) inside the domain. There the integrand grows like a
    power of the distance, which the quadtree resolves only by ever smaller cells around
    the point, and the graded map and the nested-neighbourhood audit decide it instead
    (paper section 4.3). The same holds where the refinement converged only SMOOTH_DEPTH
    or more levels deep, at its deepest cells. results: the QuadratureResults of the face's
    parts on the face's own (u, v) domain; known: points already graded. Returns a list of
    (u, v)."""
    (u0, u1), (v0, v1) = domain.u_range, domain.v_range
    gu = _grid_values(u0, u1, u_breaks)
    gv = _grid_values(v0, v1, v_breaks)
    out = []
    for r in results:
        stalled = not r.converged.get("int_abs_K", True) and len(r.unconverged_cells)
        deep = r.depth_reached >= SMOOTH_DEPTH and r.deepest_cells is not None and len(r.deepest_cells)
        if not (stalled or deep) or not len(r.peak_KJ):
            continue
        boxes = np.asarray(r.unconverged_cells if stalled else r.deepest_cells, dtype=float)
        wu = float((boxes[:, 1] - boxes[:, 0]).min())
        wv = float((boxes[:, 3] - boxes[:, 2]).min())
        pu, pv = float(r.peak_KJ[0][0]), float(r.peak_KJ[0][1])
        iu, iv = int(np.abs(gu - pu).argmin()), int(np.abs(gv - pv).argmin())
        nu, nv = float(gu[iu]), float(gv[iv])
        if abs(nu - pu) > STALL_REACH * wu or abs(nv - pv) > STALL_REACH * wv:
            continue
        if not _inside_or_on(domain, np.array([nu]), np.array([nv]))[0]:
            continue
        if any(abs(nu - a) <= 1e-12 * (u1 - u0) and abs(nv - b) <= 1e-12 * (v1 - v0)
               for a, b in list(known) + out):
            continue
        out.append((nu, nv))
    return out


def _inside_or_on(domain, U, V):
    """Which (U, V) lie in the closed trimmed domain (rectangles: all)."""
    U = np.asarray(U, dtype=float)
    if getattr(domain, "is_rectangle", False):
        return np.ones(U.shape, dtype=bool)
    span = 1e-9 * (domain.v_range[1] - domain.v_range[0])
    (u0, u1), du = domain.u_range, 1e-9 * (domain.u_range[1] - domain.u_range[0])
    # the ends of the u range as their limits from inside (the domain's sides are closed)
    idx, lo, hi = domain.v_intervals(np.clip(U, u0 + du, u1 - du))
    hit = (V[idx] >= lo - span) & (V[idx] <= hi + span)
    ok = np.zeros(U.shape, dtype=bool)
    ok[idx[hit]] = True
    return ok


def grading_radius(x0, lo, hi, breaks):
    """Half the distance from x0 to the nearest other break or end (the neighbourhood size r0)."""
    cand = np.concatenate([[lo, hi], np.asarray(breaks, dtype=float)])
    d = np.abs(cand - x0)
    d = d[d > 1e-12 * max(1.0, hi - lo)]
    return 0.5 * float(d.min()) if d.size else 0.5 * (hi - lo)


#: Exponent m of the graded map u = u0 + r s^m of a neighbourhood quadrant.
GRADING_POWER = 6


@dataclass
class Quadrant:
    """One quadrant [pu, pu + su ru] x [pv, pv + sv rv] of a point's neighbourhood."""

    pu: float
    pv: float
    su: int
    sv: int
    ru: float
    rv: float

    @property
    def box(self):
        a, b = sorted((self.pu, self.pu + self.su * self.ru))
        c, d = sorted((self.pv, self.pv + self.sv * self.rv))
        return a, b, c, d


class GradedQuadrantField:
    """Field on (s, t) in [0, 1]^2 of a quadrant through the graded map
    u = pu + su ru s^m, v = pv + sv rv t^m; J is multiplied by the map's Jacobian
    m^2 ru rv s^(m-1) t^(m-1), which removes an integrable corner singularity of |K| J
    (rho^-a with a < 2 becomes s^(m(2-a)-2)) and concentrates samples at the corner."""

    def __init__(self, face_field, q, m=GRADING_POWER):
        self.ff, self.q, self.m = face_field, q, m

    def __call__(self, s, t):
        q, m = self.q, self.m
        s = np.asarray(s, dtype=float)
        t = np.asarray(t, dtype=float)
        f = self.ff(q.pu + q.su * q.ru * s ** m, q.pv + q.sv * q.rv * t ** m)
        jac = m * m * q.ru * q.rv * s ** (m - 1) * t ** (m - 1)
        return {"J": f["J"] * jac, "K": f["K"], "H": f["H"], "regular": f["regular"]}


class ExcludedBoxesField:
    """The face field with J = 0 strictly inside given boxes (integrated separately)."""

    def __init__(self, face_field, boxes):
        self.ff = face_field
        self.boxes = np.asarray(boxes, dtype=float).reshape(-1, 4)

    def __getattr__(self, name):
        return getattr(self.ff, name)

    def __call__(self, u, v):
        return self._excluded(self.ff(u, v), np.asarray(u, dtype=float), np.asarray(v, dtype=float))

    def grid(self, u, v):
        """The field on the tensor grids u (n, a) x v (n, b) (FaceField.grid)."""
        return self._excluded(self.ff.grid(u, v), *grid_points(u, v))

    def _excluded(self, f, u, v):
        inside = np.zeros(u.shape, dtype=bool)
        for a, b, c, d in self.boxes:
            inside |= (u > a) & (u < b) & (v > c) & (v < d)
        if inside.any():
            f = dict(f)
            f["J"] = np.where(inside, 0.0, f["J"])
            f["K"] = np.where(inside, 0.0, f["K"])
            f["H"] = np.where(inside, 0.0, f["H"])
            f["regular"] = np.where(inside, True, f["regular"])
        return f


def neighbourhood_quadrants(deg, domain, u_breaks, v_breaks, points=None):
    """Quadrants of the neighbourhoods of degenerate points and hot spots, inside the domain
    (points: these instead of deg.graded_points).

    Each point gets up to four quadrants of half-widths r0 (half the distance to the
    nearest knot line or side); quadrants leaving the parameter range are dropped, and for
    a trimmed domain a quadrant is kept only if it lies inside (else the point is left to
    the ordinary adaptive quadrature)."""
    (u0, u1), (v0, v1) = domain.u_range, domain.v_range
    out = []
    for (pu, pv) in (deg.graded_points if points is None else points):
        ru = grading_radius(pu, u0, u1, u_breaks)
        rv = grading_radius(pv, v0, v1, v_breaks)
        for su in (-1, 1):
            for sv in (-1, 1):
                q = Quadrant(pu, pv, su, sv, ru, rv)
                a, b, c, d = q.box
                if a < u0 - 1e-12 * (u1 - u0) or b > u1 + 1e-12 * (u1 - u0):
                    continue
                if c < v0 - 1e-12 * (v1 - v0) or d > v1 + 1e-12 * (v1 - v0):
                    continue
                if not getattr(domain, "is_rectangle", False):
                    g = np.linspace(0.0, 1.0, 9)
                    U = np.concatenate([a + (b - a) * g, np.full(9, b), b - (b - a) * g, np.full(9, a)])
                    V = np.concatenate([np.full(9, c), c + (d - c) * g, np.full(9, d), d - (d - c) * g])
                    if not _inside_or_on(domain, U, V).all():
                        continue
                out.append(q)
    return out


def quadrant_breaks(quadrants):
    """Break lines of the quadrant boxes, so that excluded boxes are unions of cells."""
    us = [x for q in quadrants for x in q.box[:2]]
    vs = [x for q in quadrants for x in q.box[2:]]
    return np.asarray(us, dtype=float), np.asarray(vs, dtype=float)


class KZeroToRounding:
    """The face field with K = 0 where |K| <= K_ROUNDING eps (k1^2 + k2^2), k1^2 + k2^2 =
    4 H^2 - 2 K: a Gaussian curvature that is zero to the rounding of the principal
    curvatures (a cone or another developable surface towards its apex). Its noise grows
    like the curvature squared and would read as a non-integrable singularity to the
    audit's scale-free decay fit; the audits use this field."""

    def __init__(self, face_field):
        self.ff = face_field

    def __getattr__(self, name):
        return getattr(self.ff, name)

    def __call__(self, u, v):
        f = self.ff(u, v)
        K, H = f["K"], f["H"]
        with np.errstate(invalid="ignore", over="ignore"):
            zero = np.abs(K) <= K_ROUNDING * np.finfo(float).eps * np.abs(4.0 * H * H - 2.0 * K)
        if not np.any(zero):
            return f
        return {**f, "K": np.where(zero, 0.0, K)}


def audit_point(face_field, point, quadrants, totals, lref, tau_H, tau_K, order=5, rtol=1e-6,
                max_depth=3, levels=AUDIT_LEVELS, m=GRADING_POWER):
    """Nested-neighbourhood audit around a degenerate point.

    For the boxes B_k (the point's quadrants shrunk by 2^-k, r_k = r0 2^-k) it integrates the
    area A_k and E_k = int_{B_k} |K| dA (and K+, K-) through the graded map, samples max |K|
    on the boxes' outer edges, fits E_k ~ r_k^p, and forms I_D, I_D+, I_D- of the complement.
    The first AUDIT_FIRST_LEVELS boxes decide a bounded case, or a convergent one with p above
    FIRST_CLEAR_POWER; any other verdict is decided on the innermost of levels boxes (from
    AUDIT_FIT_FROM on, _staged_verdict), since a curvature peak confined to a small core shows
    its power law only there. Returns evidence
    and a verdict: 'regular' (|K| bounded: parameterisation degeneracy), 'convergent'
    (unbounded |K|, E_k -> 0 with p > CONVERGENT_POWER), 'divergent' (E_k does not decay),
    'inconclusive', or 'not_audited' (no quadrant lies inside the trimmed domain).
    """
    pu, pv = point
    face_field = KZeroToRounding(face_field)
    mine = [q for q in quadrants if (q.pu, q.pv) == (pu, pv)]
    if not mine:
        return {"point": [pu, pv], "verdict": "not_audited",
                "reason": "the neighbourhood of the point is crossed by trim curves"}
    rows, verdict, power, growth = _staged_verdict(
        lambda k: _audit_row(face_field, mine, k, totals, tau_H, tau_K, order, rtol, max_depth, m),
        levels, min(AUDIT_FIT_FROM, levels - 3))
    A, absK = totals["A_valid"], totals["int_abs_K"]
    L2 = lref ** 2
    for row in rows:
        Ac = A - row["area"]
        row["excluded_area_fraction"] = row["area"] / A if A > 0 else None
        row["excluded_abs_K_fraction"] = row["int_abs_K"] / absK if absK > 0 else None
        row["I_D_complement"] = L2 * (absK - row["int_abs_K"]) / Ac if Ac > 0 else None
        row["I_D_plus_complement"] = L2 * (totals["int_K_plus"] - row["int_K_plus"]) / Ac if Ac > 0 else None
        row["I_D_minus_complement"] = L2 * (totals["int_K_minus"] - row["int_K_minus"]) / Ac if Ac > 0 else None
    seq = [row["I_D_complement"] for row in rows if row["I_D_complement"] is not None]
    changes = [abs(b - a) / abs(b) if b else 0.0 for a, b in zip(seq[:-1], seq[1:])]
    return {"point": [pu, pv], "verdict": verdict, "decay_power": power, "max_abs_K_growth": growth,
            "I_D_relative_changes": changes, "neighbourhoods": rows}


def _audit_row(face_field, quadrants, k, totals, tau_H, tau_K, order, rtol, max_depth, m):
    """Integrals over the box B_k of a point's quadrants and max |K| on its outer edges."""
    # Only the area and the K integrals matter here: the class areas get the face's area
    # as their tolerance reference, and no cell is integrated on lines (the kink of |K| on
    # K = 0 is left to the quadtree's own error estimate).
    ref = {q: abs(totals.get("A", 0.0)) for q in ("A_flat", "A_single", "A_elliptic", "A_saddle")}
    sk = 2.0 ** (-k / m)  # s = (r / r0)^(1/m)
    acc = {"area": 0.0, "int_abs_K": 0.0, "int_K_plus": 0.0, "int_K_minus": 0.0}
    conv = True
    for q in quadrants:
        res = integrate(TrimmedDomain.rectangle(0.0, sk, 0.0, sk), GradedQuadrantField(face_field, q, m),
                        tau_H, tau_K, order=order, rtol=rtol, max_depth=max_depth, recheck=False,
                        class_max_depth=0, reference=ref, lines=False)
        acc["area"] += res.values["A"]
        for key in ("int_abs_K", "int_K_plus", "int_K_minus"):
            acc[key] += res.values[key]
        conv &= bool(res.converged["int_abs_K"])
    # |K| on the outer edges of B_k, at distance r_k from the point: its growth over the
    # boxes tells bounded from unbounded curvature (samples nearer the point may be
    # non-regular and say nothing)
    g = np.linspace(0.0, 1.0, 17)
    kmax = []
    for q in quadrants:
        f = GradedQuadrantField(face_field, q, m)(np.concatenate([np.full(g.size, sk), g * sk]),
                                                  np.concatenate([g * sk, np.full(g.size, sk)]))
        if f["regular"].any():
            kmax.append(float(np.nanmax(np.abs(np.where(f["regular"], f["K"], np.nan)))))
    return {"r_u": quadrants[0].ru * 2.0 ** -k, "r_v": quadrants[0].rv * 2.0 ** -k, **acc,
            "max_abs_K": max(kmax) if kmax else None, "converged": conv}


def _staged_verdict(row_of, levels, fit_from, unbounded=False):
    """(rows, verdict, p, growth) of nested neighbourhoods row_of(k), k = 0, 1, ...: the first
    AUDIT_FIRST_LEVELS rows decide a bounded case ('regular') or a convergent one with p above
    FIRST_CLEAR_POWER; otherwise all levels rows are made and decided from rows[fit_from:]
    (_decay_verdict)."""
    first = min(AUDIT_FIRST_LEVELS, levels)
    rows = [row_of(k) for k in range(first)]
    verdict, power, growth = _decay_verdict(rows, 0, unbounded)
    clear = verdict == "regular" or (verdict == "convergent" and power > FIRST_CLEAR_POWER)
    if not clear and levels > first:
        rows += [row_of(k) for k in range(first, levels)]
        verdict, power, growth = _decay_verdict(rows, fit_from, unbounded)
    return rows, verdict, power, growth


def _decay_verdict(rows, fit_from, unbounded=False):
    """(verdict, p, growth) of nested neighbourhoods rows (r_u, int_abs_K, max_abs_K), from
    rows[fit_from:]: the power p of E_k ~ r_k^p and the growth of max |K|. Growth below
    UNBOUNDED_GROWTH, or p >= BOUNDED_POWER (E_k shrinking with the area, as for bounded K)
    is 'regular'; else p decides 'convergent' (p > CONVERGENT_POWER), 'divergent' (p <= 0)
    or 'inconclusive'. unbounded: the growth is known to be unbounded (not tested here)."""
    r = np.array([row["r_u"] for row in rows[fit_from:]])
    E = np.array([row["int_abs_K"] for row in rows[fit_from:]])
    ok = E > 0
    power = float(np.polyfit(np.log(r[ok]), np.log(E[ok]), 1)[0]) if ok.sum() >= 3 else None
    kmax = [row["max_abs_K"] for row in rows[fit_from:] if row["max_abs_K"] is not None]
    growth = (kmax[-1] / kmax[0]) if len(kmax) >= 2 and kmax[0] > 0 else 1.0
    # bounded K: no growth, or the integral shrinking with the area (E_k ~ r_k^2)
    if (growth < UNBOUNDED_GROWTH and not unbounded) or (power is not None and power >= BOUNDED_POWER):
        return "regular", power, growth
    if power is not None and power > CONVERGENT_POWER:
        return "convergent", power, growth
    if power is not None and power <= 0.0:
        return "divergent", power, growth
    return "inconclusive", power, growth


class GradedStripField:
    """Field on (s, w) in [0, 1]^2 of the strip of width r along a side x of the parameter
    rectangle, through the graded map (u, v) = (x + sign r s^m, w') for a u side (w' the
    other parameter over its range [w0, w1]; the roles exchanged for a v side); J is
    multiplied by the map's Jacobian m r s^(m-1) (w1 - w0), and by 0 outside a trimmed
    domain when one is given (the strip's part inside the face; its integral then converges
    only like the cell size at the trim curve, enough for the decay power)."""

    def __init__(self, face_field, side, x, r, w_range, m=GRADING_POWER, domain=None):
        self.ff, self.side, self.x, self.r, self.w_range, self.m = face_field, side, x, r, w_range, m
        self.domain = domain  # a trimmed domain: J = 0 outside it

    def __call__(self, s, t):
        s = np.asarray(s, dtype=float)
        w0, w1 = self.w_range
        sign = 1.0 if self.side in ("u0", "v0") else -1.0
        a = self.x + sign * self.r * s ** self.m
        b = w0 + (w1 - w0) * np.asarray(t, dtype=float)
        u, v = (a, b) if self.side in ("u0", "u1") else (b, a)
        f = self.ff(u, v)
        jac = self.m * self.r * s ** (self.m - 1) * (w1 - w0)
        if self.domain is not None:
            shape = np.shape(u)
            jac = jac * _inside_or_on(self.domain, np.ravel(u), np.ravel(v)).reshape(shape)
        return {"J": f["J"] * jac, "K": f["K"], "H": f["H"], "regular": f["regular"]}


def probe_side(face_field, domain, side, u_breaks, v_breaks, levels=12, order=5, m=GRADING_POWER):
    """Behaviour of |K| approaching a collapsed side: max |K| on lines r_k = r0 2^-k from it
    and, where it grows, the |K| integral E_k over the strip of width r_k along the side
    (graded map GradedStripField; on a trimmed face the strip is cut by the domain), decided
    as audit_point's neighbourhoods are (_staged_verdict, the innermost from levels // 2):
    'regular' (|K| bounded), 'convergent' (p > CONVERGENT_POWER), 'divergent' (p <= 0), else
    'inconclusive'. K zero to rounding is zero (KZeroToRounding)."""
    face_field = KZeroToRounding(face_field)
    (u0, u1), (v0, v1) = domain.u_range, domain.v_range
    g = np.linspace(0.01, 0.99, 41)
    kmax, radii = [], []
    for k in range(levels):
        if side in ("v0", "v1"):
            x = v0 if side == "v0" else v1
            r = grading_radius(x, v0, v1, v_breaks) * 2.0 ** -k
            U = u0 + (u1 - u0) * g
            V = np.full_like(U, x + r if side == "v0" else x - r)
        else:
            x = u0 if side == "u0" else u1
            r = grading_radius(x, u0, u1, u_breaks) * 2.0 ** -k
            V = v0 + (v1 - v0) * g
            U = np.full_like(V, x + r if side == "u0" else x - r)
        radii.append(r)
        f = face_field(U, V)
        Kr = np.where(f["regular"], np.abs(f["K"]), np.nan)
        kmax.append(float(np.nanmax(Kr)) if np.isfinite(Kr).any() else None)
    finite = [k for k in kmax if k is not None]
    growth = finite[-1] / finite[0] if len(finite) >= 2 and finite[0] > 0 else 1.0
    out = {"side": side, "max_abs_K_growth": growth, "max_abs_K": kmax}
    if growth < UNBOUNDED_GROWTH:
        out["verdict"] = "regular"
        return out
    x = {"u0": u0, "u1": u1, "v0": v0, "v1": v1}[side]
    trimmed = not getattr(domain, "is_rectangle", False)
    w_range = (v0, v1) if side in ("u0", "u1") else (u0, u1)

    def strip(k):
        r = radii[k]
        res = integrate(TrimmedDomain.rectangle(0.0, 1.0, 0.0, 1.0),
                        GradedStripField(face_field, side, x, r, w_range, m, domain if trimmed else None),
                        1.0, 1.0, order=order, rtol=1e-6, max_depth=3, recheck=False, class_max_depth=0, lines=False)
        return {"r_u": r, "int_abs_K": res.values["int_abs_K"], "max_abs_K": kmax[k]}

    rows, verdict, power, _ = _staged_verdict(strip, levels, levels // 2, unbounded=True)
    out["strip_abs_K"] = [row["int_abs_K"] for row in rows]
    out["decay_power"] = power
    out["verdict"] = verdict
    return out
