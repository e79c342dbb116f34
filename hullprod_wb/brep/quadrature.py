"""Adaptive boundary-fitted Gauss-Legendre cubature over a trimmed face domain
(paper eq:brep_surface_integral, section 4.1; settings of section 5.2).

Integrals over Omega, the face's trimmed (u, v) domain, of phi J du dv for the quantities
of the signature: represented area A = int J, valid area (regular points), int |K| J,
int max(K,0) J, int max(-K,0) J over the valid points, and the four curvature-class areas
of eq:curvature_classes.

Geometry. The domain is cut into boundary-fitted patches mapped from the unit square
(hullprod_wb.brep.patches: strips lo(u) <= v <= hi(u) between breakpoints, knot lines and the
trim curves' crossings of the knot lines), on which the integrands are smooth, so that
Gauss-Legendre converges fast on the exact trimmed region.

Quadtree. Tensor Gauss-Legendre of the given order on cells of a quadtree over each patch;
all cells of a level are evaluated in one field call. A domain of fewer than
MIN_INITIAL_CELLS patches starts from the patches halved in both directions (those levels
count as done: max_depth stays the number of levels below the patches). A cell that meets
no class boundary is accepted on its own Gauss sums when the difference to the embedded
lower-degree rule on the same nodes (gauss_rules.embedded_weights) fits OWN_SAFETY of the
budget; otherwise its four children are evaluated. Error estimate of a parent cell:
|Q(cell) - sum of Q over its 4 children| (coarse against fine resolution; it estimates the
coarse rule's error, so it is conservative for the children's sum, which is what is kept). The
tolerance of quantity q is tol_q = rtol max(|Q_q|, ZERO_SCALE s_q, reference_q), s_q = A
for areas and tau_K A for K integrals. A level whose accepted plus new error estimates fit
every tol_q ends the refinement. Otherwise the candidates are the cells that fit, greedily
(smallest errors first, using at most ACCEPT_FRACTION of the budget left), TREE_SAFETY of
the budget of the smooth quantities (areas; K integrals of cells without a level curve):
the quadtree is cheap, and this keeps their actual error far inside rtol. The candidates'
line integrals (below) are then computed, and the candidates accepted greedily again on
every quantity against the whole budget left; the others are split, until max_depth.

Mixed cells. The class indicators are discontinuous, and |K|, max(+-K, 0) have kinks on
K = 0; Gauss sums across such curves converge only like the cell size (squared). A cell is
mixed when its samples do not all have one class, or when the sampled range of K (or of H
where |K| may be below tau_K), widened by STRADDLE_MARGIN of itself, contains -tau_K or tau_K
(or -+tau_H), or K changes sign in it. For a parent cell with a mixed child the K integrals
and class areas are line integrals over the parent, taken on the tensor interpolant of J, K,
H through its children's samples (hullprod_wb.brep.cell_interpolant) when the interpolant's
error, measured at the parent's own nodes and propagated to each integral, is within
INTERPOLANT_SHARE of the cell's budget (it then adds to the cell's error); a cell whose
interpolant is not yet that accurate is split instead, and at the last level its lines run
on the field itself. A cell on its interpolant in an affine patch (one constant area element)
whose K varies more along sigma than along t takes its lines along sigma instead (sigma and t
exchanged, _Integrator._turn_cells): its level curves then cross the lines instead of running
beside them, and cross the cell's t edges (each crossing a cut, below) far less often:
- on a line sigma = const, the crossings in t of K - tau_K, K + tau_K, H - tau_H, H + tau_H
  and K are bracketed between the samples ZS (and around extrema of one sign that get
  near zero between samples) and refined together; each piece between crossings has one
  class and one sign of K. K = 0 lies inside the band |K| <= tau_K (flat or single
  pieces), where the K integrals are at most tau_K times the area: it is refined only
  once the bounds charged instead (a piece's K integral taken with its own sign, error at
  most tau_K A - |int K J|) would exceed ZERO_CHARGE_SHARE of the K integrals'
  tolerances (near-developable surfaces), from then on. On a line of an interpolant (a
  Legendre series in t, see cell_interpolant.SegmentField) the crossings are refined by
  safeguarded Newton on the series and J, K J are integrated over each piece exactly
  (antiderivatives of the series and of their product), so the line adds no error of its
  own beyond those bounds; on a line of the field the
  crossings are refined by solve_bracketed (one field call per step) and J, K J are
  integrated by Gauss-Kronrod 3/7, with the integral of their interpolants at ZS as the
  comparison for the error estimate (on pieces shorter than SHORT_PIECE of the line, the
  interpolants, against those of lower degree);
- in sigma the cell is cut where level curves cross its t edges (kinks of the line values),
  where they are tangent to the lines (found between lines whose crossing counts
  differ; square-root ends, so those pieces get a clustered map), and, on interpolants,
  at the corners of the flat region, where a level of H meets one of K (found where H -+
  tau_H changes sign along a crossing of K = +-tau_K between lines, then by Newton on the
  pair of level equations; kinks of the class areas' line integrals, and the only trace
  of a flat region that lies between two lines), and through islands of a class that no
  line of an interpolant's cell meets (where the lines miss a part that the interpolant's
  Bernstein bounds allow, the extremum of K is searched), and the pieces are
  integrated by Gauss-Kronrod 3/7 (error |K7 - G3|), halving those whose error does not
  fit, at most class_max_depth times;
- on lines of the field, the quadtree's own children sums of the K integrals bound the
  line error estimate from below where both disagree (a rough or singular integrand the
  lines do not resolve); an interpolant has passed the sharper check above.
Islands of a level curve inside a cell that no sample sees (a cell that is not mixed), or
inside a cell on the field between its lines, are not resolved.
"""
import time
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..core.errors import InputError
from ..core.integrals import SurfaceIntegrals
from ..core.thresholds import check_positive, classify
from .cell_interpolant import (SegmentField, _local, cell_values, fit_interpolants, grid_matrices, horner,
                               interpolant_extremum, interpolant_range, level_intersections,
                               tangency_points, window_min_of)
from .gauss_rules import (WK, XK, embedded_weights, gauss_nodes, kronrod_error, legendre_vander,
                          piece_weights)
from .nurbs import grid_points
from .patches import Patches, cluster_map
from .trimmed_domain import TrimmedDomain, solve_bracketed

#: Names of the integrated quantities, in the order of the value arrays.
QUANTITIES = ("A", "A_valid", "int_abs_K", "int_K_plus", "int_K_minus",
              "A_flat", "A_single", "A_elliptic", "A_saddle")
NQ = len(QUANTITIES)
#: Quantities integrated on lines in mixed cells (K integrals and class areas), and
#: the number of level functions whose crossings cut the lines.
LINE_Q = slice(2, 9)
N_LINE_Q = 7
N_LEVELS = 5
N_SMOOTH = 5
#: Quantities below this fraction of their natural scale (A, tau_K A) count as zero.
ZERO_SCALE = 1e-2
#: The quadtree's own acceptance uses this fraction of the tolerances of the smooth
#: quantities (cheap to refine; their error then stays well inside rtol).
TREE_SAFETY = 1e-2
#: Cells accepted on their own Gauss sums may use this fraction of the tolerances: their
#: estimate is the error of the embedded lower-degree rule (degree 2o - 1 against o - 2 per
#: direction), itself a large overestimate of the Gauss rule's error on smooth integrands.
OWN_SAFETY = 0.1
#: Part of the remaining error budget a level may use up by accepting cells.
ACCEPT_FRACTION = 0.5
#: Widening of a cell's sampled K (H) range when testing whether it meets a level.
STRADDLE_MARGIN = 0.5
#: Relative precision of level crossings on a line (of the line's parameter range), and
#: the most steps spent on one (every step is a field call for all of them): a near-double
#: crossing (a level curve almost tangent to the line, where the two crossings bound a
#: sliver of vanishing area) converges only like bisection and may end within 2^-14 of its
#: sample interval.
CROSSING_RTOL = 1e-12
CROSSING_STEPS = 14
#: Parabolic-interpolation steps locating the extremum of a level function along a line.
PARABOLIC_STEPS = 3
#: A dip of three samples is searched for crossings when the vertex of their parabola gets
#: within this fraction of the middle sample's value from zero.
DIP_FRACTION = 0.2
#: Relative precision of a tangency cut in sigma (a cut off by d leaves an error ~ d^1.5),
#: and the most steps spent on finding one.
TANGENT_RTOL = 1e-6
TANGENT_STEPS = 10
#: Crossings of K = 0 (a kink of |K|, max(+-K, 0)) lie inside the band |K| <= tau_K, in flat
#: or single pieces of the lines, where the K integrals are bounded by tau_K times the area.
#: The lines are not cut there while the bounds charged to the K integrals' error estimates
#: instead (_Integrator._line_values; a part ZERO_CHARGE_PARTS of the bound to |K|, K+, K-)
#: stay within ZERO_CHARGE_SHARE of their tolerances; beyond that K = 0 is resolved.
#: The bound of |K| on a line is at most ZERO_BOUND_SAFETY times its largest sampled |K|.
ZERO_CHARGE_SHARE = 0.1
ZERO_CHARGE_PARTS = np.array([1.0, 0.5, 0.5])
ZERO_BOUND_SAFETY = 2.0
#: Line pieces are not halved further once halving keeps this much of their error, nor in a
#: cell that holds this many pieces (the quadtree refines such cells instead).
STALL_RATIO = 0.45
MAX_PIECES = 64
#: A mixed cell's lines are taken on its local interpolant (see _Integrator._interpolants)
#: when the interpolant's error estimate is within this share of the cell's budget.
INTERPOLANT_SHARE = 0.1
#: A face of at least GROUP_MIN_PATCHES boundary-fitted patches is integrated as GROUPS
#: ranges of consecutive patches, each an adaptive integration of its own (as separate
#: faces are), which processes can share (see patch_groups).
GROUPS = 2
GROUP_MIN_PATCHES = 256
#: An integration starts from at least MIN_INITIAL_CELLS cells: the patches, halved in both
#: directions as often as needed (at most to one level above max_depth; the levels so
#: skipped count as done, so max_depth keeps its meaning: levels below the patches). Each
#: quadtree level whose cells are integrated on lines costs a pass of several milliseconds
#: whatever its number of cells, and a cell of a quarter of a curved face or more is hardly
#: ever accepted: on a face of one to a few patches the first levels cost such passes for a
#: handful of cells.
MIN_INITIAL_CELLS = 16
#: Cells a step of NodePrefetch evaluates (a few milliseconds).
PREFETCH_CELLS = 256
#: Number of candidate cells of largest |K| J kept for the singular-point audit.
N_PEAKS = 10
#: At most this many non-regular sample locations are kept.
MAX_NONREGULAR = 10000
#: Boxes of the deepest accepted cells kept in a result (where the refinement went deepest).
N_DEEPEST = 64


@dataclass
class QuadratureResult:
    """Integrals over one face with their evidence.

    values, errors, tolerances: dict quantity (see QUANTITIES) -> float; values are the
    finite candidates, also where not converged. converged: dict quantity -> bool, error
    estimate within tolerance at depth <= max_depth. n_points: field points evaluated;
    n_field_calls; depth_reached: deepest quadtree level evaluated; n_cells: leaf cells;
    n_initial_cells: the first cells (the patches, halved up to MIN_INITIAL_CELLS);
    n_mixed_cells: cells integrated on lines. nonregular_uv (m, 2): (u, v) of sampled
    non-regular points (at most MAX_NONREGULAR; n_nonregular counts all). unconverged_cells
    (k, 4): [u_min, u_max, v_min, v_max] of cells left unresolved at the final depth.
    peak_KJ (N_PEAKS, 3): (u, v, |K| J) of the samples of largest |K| J, one per cell,
    largest first (candidate singular points). recheck: the
    integration continued one level deeper (paper section 5.2) when something did not
    converge and recheck was requested, else None. history: the global estimate of every
    quantity after each quadtree level (level 0: the patches' own Gauss sums, or those of the
    first cells where the patches were halved before (their level's estimate stands for the
    levels above it); level d: accepted cells plus the Gauss sums of the cells still
    refined), a list of dicts quantity -> float: the refinement sequence of the stability
    rule (section 5.2).
    zero_resolved: crossings of K = 0 cut the lines of mixed cells (else the bounds charged
    instead, zero_charge, within ZERO_CHARGE_SHARE of the K integrals' tolerances, are part
    of their error estimates; see _Integrator._line_values).
    """

    values: dict
    errors: dict
    tolerances: dict
    converged: dict
    order: int
    rtol: float
    max_depth: int
    depth_reached: int
    n_points: int
    n_field_calls: int
    n_cells: int
    n_initial_cells: int
    n_mixed_cells: int
    nonregular_uv: np.ndarray
    n_nonregular: int
    unconverged_cells: np.ndarray
    peak_KJ: np.ndarray
    seconds: float = 0.0
    recheck: Optional["QuadratureResult"] = None
    history: Optional[list] = None
    zero_resolved: bool = False
    zero_charge: float = 0.0
    point_budget: Optional[int] = None
    budget_spent: bool = False
    deepest_cells: Optional[np.ndarray] = None

    @property
    def all_converged(self):
        return all(self.converged.values())

    @property
    def class_areas(self):
        """(4,) flat, single, elliptic, saddle areas."""
        return np.array([self.values[q] for q in QUANTITIES[N_SMOOTH:]])

    def integrals(self):
        """The values as a core SurfaceIntegrals record."""
        v = self.values
        return SurfaceIntegrals(v["A"], v["A_valid"], v["int_abs_K"], v["int_K_plus"],
                                v["int_K_minus"], self.class_areas)

    def to_dict(self):
        """Plain data (lists for the location arrays)."""
        out = {k: getattr(self, k) for k in ("values", "errors", "tolerances", "converged", "order",
                                             "rtol", "max_depth", "depth_reached", "n_points",
                                             "n_field_calls", "n_cells", "n_initial_cells",
                                             "n_mixed_cells", "n_nonregular", "seconds",
                                             "zero_resolved", "zero_charge", "point_budget",
                                             "budget_spent")}
        out["nonregular_uv"] = self.nonregular_uv.tolist()
        out["unconverged_cells"] = self.unconverged_cells.tolist()
        out["peak_KJ"] = self.peak_KJ.tolist()
        out["deepest_cells"] = None if self.deepest_cells is None else self.deepest_cells.tolist()
        out["history"] = self.history
        out["recheck"] = None if self.recheck is None else self.recheck.to_dict()
        return out


class _Field:
    """Calls the user's field and normalises its output to (J, K, H, regular) arrays."""

    def __init__(self, field):
        self.field = field
        self.n_points = 0
        self.n_calls = 0

    def __call__(self, u, v):
        u = np.ascontiguousarray(u, dtype=float).ravel()
        v = np.ascontiguousarray(v, dtype=float).ravel()
        if u.size == 0:
            e = np.empty(0)
            return e, e, e, np.empty(0, bool)
        return self._normalised(self.field(u, v), u.size)

    def grid(self, u, v):
        """The field on the tensor grids u (n, a) x v (n, b), flat in [c, i, j] order: through
        the field's own grid(u, v) where it has one (FaceField.grid), else point by point."""
        U, V = grid_points(u, v)
        if not hasattr(self.field, "grid") or U.size == 0:
            return self(U, V)
        return self._normalised(self.field.grid(u, v), U.size)

    def _normalised(self, res, n):
        """(J, K, H, regular) (n,) of a field's result; J = 0 and not regular where J is not finite."""
        get = res.get if isinstance(res, dict) else (lambda k, d=None: getattr(res, k, d))
        try:
            J, K, H = (np.asarray(get(k), dtype=float).ravel() for k in ("J", "K", "H"))
        except (TypeError, ValueError) as exc:
            raise InputError("integrand field must return arrays J, K, H (and regular): %s"
                             % exc) from exc
        reg = get("regular", None)
        reg = np.ones(n, bool) if reg is None else np.asarray(reg, dtype=bool).ravel()
        if not (J.size == K.size == H.size == reg.size == n):
            raise InputError("integrand field returned arrays of sizes %s for %d points"
                             % ((J.size, K.size, H.size, reg.size), n))
        bad = ~np.isfinite(J)
        reg = reg & ~bad & np.isfinite(K) & np.isfinite(H)
        self.n_points += n
        self.n_calls += 1
        return np.where(bad, 0.0, J), K, H, reg


#: Lines of a piece in its parameter: next to each end (for tangency detection only) and
#: at the Kronrod nodes.
EDGE_XI = 1e-5
XI9 = np.concatenate(([EDGE_XI], XK, [1.0 - EDGE_XI]))
#: Samples of a line (fraction of its length): next to the ends (INSIDE: a cell's edge
#: may be a knot line or a box edge where the field jumps; every sample stays in the cell)
#: and at the 3/7 Kronrod nodes. They bracket level crossings and carry the degree-8
#: interpolants of J and K J (degree 6 on the inner 7 for error estimates).
INSIDE = 1e-9
ZS = np.concatenate(([INSIDE], XK, [1.0 - INSIDE]))
#: Pieces of a line shorter than this fraction of it (between nearby crossings) are
#: integrated over the interpolants, without samples of their own.
SHORT_PIECE = 1e-3
#: Pieces of a cell narrower in sigma than this fraction of it (slivers between nearby
#: kinks) are integrated by the 2-point Gauss rule on lines at XI3 (nodes, then midpoint).
SLIVER = 1e-3
XI3 = np.array([0.5 - 0.5 / np.sqrt(3.0), 0.5, 0.5 + 0.5 / np.sqrt(3.0)])


M_HI = piece_weights(ZS)
M_LO = piece_weights(ZS[1:-1])



#: Field row (SegmentField: 0 J, 1 K, 2 H) of each level function of _Integrator._thresholds.
LEVEL_ROW = np.array([1, 1, 2, 2, 1])


def _greedy_accept(err, budget, group=None):
    """Cells accepted by spending at most ACCEPT_FRACTION of an error budget greedily.

    err (n, q) error estimates; budget (q,), or (g, q) per group with group (n,) int.
    Within each group cells are taken in increasing order of max_q err/budget while the
    running sum of err stays within ACCEPT_FRACTION * budget for every q. Returns (n,) bool.
    """
    n = err.shape[0]
    if group is None:
        group = np.zeros(n, int)
        budget = np.asarray(budget)[None, :]
    B = ACCEPT_FRACTION * np.maximum(budget[group], 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(err > 0.0, err / B, 0.0)
    key = np.nan_to_num(ratio, nan=np.inf).max(1)
    order = np.lexsort((key, group))
    g, e = group[order], err[order]
    csum = np.cumsum(e, 0)
    first = np.r_[True, g[1:] != g[:-1]]
    start = np.maximum.accumulate(np.where(first, np.arange(n), 0))
    base = np.where(start[:, None] > 0, csum[np.maximum(start - 1, 0)], 0.0)
    fits = np.all(csum - base <= B[order], 1)
    fails = np.cumsum(~fits)
    fails_before = fails - np.where(start > 0, fails[np.maximum(start - 1, 0)], 0)
    out = np.empty(n, bool)
    out[order] = fits & (fails_before == 0)
    return out


def _row_sums(rows, values, n):
    """Sums (n, q) of the rows (k, q) of values that belong to each index of rows (k,)."""
    out = np.empty((n, values.shape[1]))
    for j in range(values.shape[1]):
        out[:, j] = np.bincount(rows, weights=values[:, j], minlength=n)
    return out


def _segments(cuts, owner):
    """Consecutive pairs of sorted cut values per owner: (owner, a, b) of non-empty pieces.

    cuts, owner (k,); every owner must have its two end values among the cuts."""
    o = np.lexsort((cuts, owner))
    c, w = cuts[o], owner[o]
    k = np.nonzero((w[:-1] == w[1:]) & (c[1:] > c[:-1]))[0]
    return w[k], c[k], c[k + 1]


def _count_and_pairs(line, level, roots, L):
    """Crossings per line and level, count (L, 5), the closest two of each, pair
    (L, 5, 2) (NaN when fewer than two), and the first and last of each, ends (L, 5, 2) (NaN
    when none), from roots (k,) of lines line (k,), levels (k,)."""
    key = line * N_LEVELS + level
    count = np.bincount(key, minlength=N_LEVELS * L).reshape(L, N_LEVELS)
    pair = np.full((L, N_LEVELS, 2), np.nan)
    ends = np.full((L, N_LEVELS, 2), np.nan)
    o = np.lexsort((roots, key))
    key, r = key[o], roots[o]
    if key.size:
        new = np.r_[True, key[1:] != key[:-1]]
        ends.reshape(-1, 2)[key[new], 0] = r[new]
        last = np.r_[new[1:], True]
        ends.reshape(-1, 2)[key[last], 1] = r[last]
    k = np.nonzero(key[1:] == key[:-1])[0]
    if k.size:
        k = k[np.lexsort((r[k + 1] - r[k], key[k]))]
        k = k[np.r_[True, key[k][1:] != key[k][:-1]]]
        pair.reshape(-1, 2)[key[k]] = np.stack((r[k], r[k + 1]), 1)
    return dict(count=count, pair=pair, ends=ends)


def _parabolic_min(fun, x, f, steps=PARABOLIC_STEPS):
    """Local minima by successive parabolic interpolation, all at once.

    x, f (n, 3): a bracket x0 < x1 < x2 with f1 <= f0, f2 (the middle one lowest).
    fun(x, index) evaluates at x (m,) for the brackets index (m,); one call per step. Each
    step evaluates the vertex of the parabola through the bracket (or, when that is not
    usable, a point 0.38 into the longer side) and keeps the lowest point with its two
    neighbours. Returns x (n,) and f (n,) of the lowest point."""
    x, f = np.array(x, dtype=float), np.array(f, dtype=float)
    idx = np.arange(x.shape[0])
    for _ in range(steps):
        x0, x1, x2 = x.T
        f0, f1, f2 = f.T
        with np.errstate(divide="ignore", invalid="ignore"):
            p = (x1 - x0) ** 2 * (f1 - f2) - (x1 - x2) ** 2 * (f1 - f0)
            q = (x1 - x0) * (f1 - f2) - (x1 - x2) * (f1 - f0)
            xv = x1 - 0.5 * p / q
        gap = 1e-3 * (x2 - x0)
        usable = np.isfinite(xv) & (xv > x0 + gap) & (xv < x2 - gap) & (np.abs(xv - x1) > gap)
        longer_right = (x2 - x1) > (x1 - x0)
        fallback = np.where(longer_right, x1 + 0.381966 * (x2 - x1), x1 - 0.381966 * (x1 - x0))
        xn = np.where(usable, xv, fallback)
        fn = np.asarray(fun(xn, idx), dtype=float)
        better = fn < f1
        left = xn < x1
        # new bracket: (x0, xn, x1), (xn, x1, x2), (x1, xn, x2) or (x0, x1, xn)
        nx = np.where((left & better)[:, None], np.stack((x0, xn, x1), 1),
                      np.where((left & ~better)[:, None], np.stack((xn, x1, x2), 1),
                               np.where(better[:, None], np.stack((x1, xn, x2), 1),
                                        np.stack((x0, x1, xn), 1))))
        nf = np.where((left & better)[:, None], np.stack((f0, fn, f1), 1),
                      np.where((left & ~better)[:, None], np.stack((fn, f1, f2), 1),
                               np.where(better[:, None], np.stack((f1, fn, f2), 1),
                                        np.stack((f0, f1, fn), 1))))
        x, f = nx, np.where(np.isfinite(nf), nf, np.inf)
    return x[:, 1], f[:, 1]


def _split_pieces(pc, piece, at):
    """Pieces pc (dict of (n,) cell, sa, sb, kind) cut at sigma values at (k,) of pieces
    piece (k,); the new ends are clustered (cluster_map), old ends keep their clustering."""
    if piece.size == 0:
        return {k: v[:0] for k, v in pc.items()}
    ids = np.unique(piece)
    cuts = np.concatenate((pc["sa"][ids], at, pc["sb"][ids]))
    owner = np.concatenate((ids, piece, ids))
    w, a, b = _segments(cuts, owner)
    keep_lo = (a == pc["sa"][w]) & (pc["kind"][w] & 1 > 0)
    keep_hi = (b == pc["sb"][w]) & (pc["kind"][w] & 2 > 0)
    lo_tan = (a != pc["sa"][w]) | keep_lo
    hi_tan = (b != pc["sb"][w]) | keep_hi
    return dict(cell=pc["cell"][w], sa=a, sb=b, kind=lo_tan.astype(int) + 2 * hi_tan.astype(int),
                perr=np.full(w.size, np.inf), sib=np.full(w.size, -1))


def _halve_pieces(pc, mask, err):
    """The two halves (in sigma) of the pieces pc[mask]; each keeps its outer clustering,
    and records its parent's error err[mask] (n,) and a sibling id (its parent's index)."""
    cell, sa, sb, kind = (pc[k][mask] for k in ("cell", "sa", "sb", "kind"))
    mid = 0.5 * (sa + sb)
    return dict(cell=np.repeat(cell, 2), sa=np.stack((sa, mid), 1).ravel(),
                sb=np.stack((mid, sb), 1).ravel(), kind=np.stack((kind & 1, kind & 2), 1).ravel(),
                perr=np.repeat(err[mask], 2), sib=np.repeat(np.nonzero(mask)[0], 2))


def _inside_pieces(pc, piece, at):
    """Whether the sigma values at (k,) lie inside the pieces piece (k,) of pc, farther than
    EDGE_XI of their width from both ends (a cut there would leave a needless sliver)."""
    w = pc["sb"][piece] - pc["sa"][piece]
    return (at > pc["sa"][piece] + EDGE_XI * w) & (at < pc["sb"][piece] - EDGE_XI * w)


def _share_area_error(err, Q):
    """err (n, 9) with the class areas' columns set to the area's error shared by each
    cell's class fractions (from its integrals Q (n, 9)): outside mixed cells a class area
    is the area of the cell's one class."""
    frac = Q[:, N_SMOOTH:] / np.maximum(Q[:, :1], 1e-300)
    err[:, N_SMOOTH:] = err[:, :1] * np.abs(frac)
    return err


def _patch_cells(patches, patch_range=None, max_depth=None):
    """The quadtree's first cells (dict of (n,) pid, s0, s1, t0, t1) and their level: the
    whole of each patch of patch_range (start, stop) (default all), at level 0, halved in
    both directions (_children) until there are MIN_INITIAL_CELLS of them, at most to level
    max_depth - 1 (None: no halving); InputError when the range holds no patch."""
    pid = np.arange(patches.size)
    if patch_range is not None:
        pid = pid[slice(*patch_range)]
        if pid.size == 0:
            raise InputError("patch range %r holds none of the domain's %d patches"
                             % (tuple(patch_range), patches.size))
    z, o = np.zeros(pid.size), np.ones(pid.size)
    cells, level = dict(pid=pid, s0=z, s1=o, t0=z, t1=o), 0
    while max_depth is not None and cells["pid"].size < MIN_INITIAL_CELLS and level < max_depth - 1:
        cells, level = _children(cells), level + 1
    return cells, level


def _children(a):
    """The four children (dict of (4n,) pid, s0, s1, t0, t1) of the cells a, each cell's
    children consecutive: (low, low), (high, low), (low, high), (high, high) in (sigma, t)."""
    sm = 0.5 * (a["s0"] + a["s1"])
    tm = 0.5 * (a["t0"] + a["t1"])
    return dict(pid=np.repeat(a["pid"], 4),
                s0=np.stack((a["s0"], sm, a["s0"], sm), 1).ravel(),
                s1=np.stack((sm, a["s1"], sm, a["s1"]), 1).ravel(),
                t0=np.stack((a["t0"], a["t0"], tm, tm), 1).ravel(),
                t1=np.stack((tm, tm, a["t1"], a["t1"]), 1).ravel())


class NodePrefetch:
    """The field at the Gauss nodes of the first two quadtree levels of an integration (its
    first cells, then the four children of each), evaluated before the class thresholds are
    known (they depend on L_ref, which may still be on its way): integrate(prefetch=...)
    takes these values, and the nodes' cell_nodes geometry, instead of computing them again,
    so its results are the same to the bit. step() evaluates the next PREFETCH_CELLS cells and tells whether any are
    left; levels not completed are evaluated by the integration as usual. Children of
    patches that the integration accepts on their own are evaluated in vain; the
    integration's n_points count the values it takes over (the same count as without a
    prefetch). Arguments as integrate's; patches: the domain's Patches when already made."""

    def __init__(self, domain, field, order=5, u_breaks=(), v_breaks=(), patch_range=None, patches=None,
                 max_depth=5):
        self.f = _Field(field)
        self.order = int(order)
        self.x, _ = gauss_nodes(self.order)
        self.patches = patches if patches is not None else Patches.of(domain, u_breaks, v_breaks)
        self.cells = [_patch_cells(self.patches, patch_range, int(max_depth))[0]]
        self.cells.append(_children(self.cells[0]))
        self.values = []  # per level evaluated: J, K, H, regular (n, o, o)
        self.nodes = []  # and its nodes: U, V (n, o, o), du, lo, hi (n, o) (cell_nodes)
        self.calls = []  # and the field calls it took
        self._chunks = []  # the level being evaluated, by PREFETCH_CELLS cells

    def step(self):
        """Evaluate the next PREFETCH_CELLS cells (a step stays short: it is not interrupted
        when the thresholds arrive); whether anything is left after it."""
        level = len(self.values)
        if level < len(self.cells):
            c = self.cells[level]
            a = len(self._chunks) * PREFETCH_CELLS
            k = slice(a, min(a + PREFETCH_CELLS, c["pid"].size))
            nodes = cell_nodes(self.patches, c["pid"][k], c["s0"][k], c["s1"][k], c["t0"][k], c["t1"][k],
                               self.x)
            before = self.f.n_calls
            values = values_at_nodes(self.f, self.f.grid, tensor_cells(self.patches, c["pid"][k]), *nodes[:2])
            self._chunks.append((values, nodes, self.f.n_calls - before))
            if k.stop == c["pid"].size:  # the level is complete
                for out, part in ((self.values, 0), (self.nodes, 1)):
                    out.append(tuple(np.concatenate(v) for v in zip(*(ch[part] for ch in self._chunks))))
                self.calls.append(sum(ch[2] for ch in self._chunks))
                self._chunks = []
        return len(self.values) < len(self.cells)


def _cat(parts):
    """Concatenate a list of dicts of arrays key by key."""
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


class _Integrator:
    """State of one adaptive integration (quadtree over the patches, lines in mixed cells).

    Units of the result are accepted parent cells: their four children's Gauss sums give
    the values, or the lines for the LINE_Q quantities of mixed cells."""

    def __init__(self, domain, field, tau_H, tau_K, order, rtol, class_max_depth, u_breaks,
                 v_breaks, progress, patch_range=None, prefetch=None, max_depth=None):
        self.prefetch = prefetch
        self.f = _Field(field)
        self.tau_H, self.tau_K = tau_H, tau_K
        # constants the level functions subtract from their field row (LEVEL_ROW)
        self.level_offset = np.array([tau_K, -tau_K, tau_H, -tau_H, 0.0])
        self.order, self.rtol = order, rtol
        self.class_max_depth = class_max_depth
        self.lines = True
        # K = 0 cuts the lines only once the bounds charged instead would not fit
        # (_line_values, refine_to); zero_charge: the bounds charged in accepted cells
        self.resolve_zero = False
        self.zero_charge = 0.0
        self.progress = progress
        self.reference = np.zeros(NQ)  # see integrate(reference=...)
        self.x, self.w = gauss_nodes(order)
        self.w_embedded = embedded_weights(self.x)
        self._grid_inverse, self._parent_vander = grid_matrices(self.x)
        self.patches = Patches.of(domain, u_breaks, v_breaks) if prefetch is None else prefetch.patches
        self.active, level = _patch_cells(self.patches, patch_range, max_depth)
        self.max_depth = max_depth if max_depth is not None else 0
        pid = self.active["pid"]
        if prefetch is not None and (prefetch.order != order or not all(
                np.array_equal(prefetch.cells[0][k], self.active[k]) for k in ("pid", "s0", "t0"))):
            raise InputError("the prefetched nodes are of another order, patch range or max_depth")
        P = pid.size
        self.n_initial = P
        self.nonregular = []
        self.n_nonregular = 0
        self.accepted = []  # dicts of arrays of accepted units, one per level
        self.err_acc = np.zeros(NQ)
        self.depth = level
        self.pending = None  # units left unaccepted at the last level
        self.budget_spent = False  # refinement stopped by the point budget (refine_to)
        self.point_budget = None
        self.active.update(self._eval_cells(self.active, self._prefetched(0)))
        if prefetch is not None:
            self.active["row"] = np.arange(P)  # the first cell of each active cell (_prefetched)
        self.history = []
        self._record_level()
        self.history *= level + 1  # the levels above the first cells': their estimate

    def _record_level(self):
        """Append the global estimate (accepted cells plus active cells' Gauss sums)."""
        Q = sum((p["Q"].sum(0) for p in self.accepted), self.active["Q"].sum(0))
        self.history.append({q: float(x) for q, x in zip(QUANTITIES, Q)})

    # -- evaluation ---------------------------------------------------------------------------

    def _thresholds(self, K, H):
        """(n, 5) level functions K - tau_K, K + tau_K, H - tau_H, H + tau_H, K: the field of
        LEVEL_ROW minus level_offset."""
        rows = (None, K, H)
        return np.stack([rows[r] for r in LEVEL_ROW], -1) - self.level_offset

    def _integrands(self, J, K, H, reg):
        """(..., 9) integrands of QUANTITIES at samples (...)."""
        cls = classify(K, H, self.tau_H, self.tau_K, reg)
        Kv = np.where(reg, K, 0.0)
        Jv = np.where(reg, J, 0.0)
        out = [J, Jv, Jv * np.abs(Kv), Jv * np.maximum(Kv, 0.0), Jv * np.maximum(-Kv, 0.0)]
        out += [Jv * (cls == c) for c in range(4)]
        return np.stack(out, -1), cls

    def _prefetched(self, level, rows=None):
        """(J, K, H, regular (n, o, o), and the nodes U, V, du, lo, hi as cell_nodes gives
        them) of the prefetched level 0 (the first cells) or 1 (the children of the first
        cells rows (m,), n = 4 m) from the NodePrefetch, None when it has not evaluated that
        level."""
        p = self.prefetch
        if p is None or len(p.values) <= level or (level > 0 and rows is None):
            return None
        vals, nodes = p.values[level], p.nodes[level]
        if level > 0:
            idx = (4 * rows[:, None] + np.arange(4)).ravel()
            vals, nodes = tuple(v[idx] for v in vals), tuple(a[idx] for a in nodes)
        # counted as if evaluated here: n_points are the points the integration uses
        self.f.n_points += vals[0].size
        self.f.n_calls += p.calls[level]
        return vals, nodes

    def _eval_cells(self, c, prefetched=None):
        """Tensor Gauss rule on (sigma, t) cells c (dict of (n,) pid, s0, s1, t0, t1), with the
        field's values at its nodes and the nodes when given (_prefetched; else computed).

        Returns dict Q (n, 9), mixed (n,) bool, peak (n, 3) (u, v, |K| J at the sample of
        largest |K| J), err_e (n, 9) |Q - Q_embedded| (gauss_rules.embedded_weights), pmeas (n,)
        parameter area, and the samples sJ, sK, sH, sreg (n, o, o)
        (index [cell, sigma node, t node])."""
        x, w = self.x, self.w
        pid, s0, s1, t0, t1 = (c[k] for k in ("pid", "s0", "s1", "t0", "t1"))
        nc = pid.size
        if prefetched is not None:
            (J, K, H, reg), (U, V, du, lo, hi) = prefetched
        else:
            U, V, du, lo, hi = cell_nodes(self.patches, pid, s0, s1, t0, t1, x)
            J, K, H, reg = values_at_nodes(self.f, self.f.grid, tensor_cells(self.patches, pid), U, V)
        W = ((s1 - s0) * (t1 - t0))[:, None, None] * (w[:, None] * w[None, :])[None] \
            * (du * (hi - lo))[:, :, None]
        f, cls = self._integrands(J, K, H, reg)
        Q = np.einsum("cij,cijq->cq", W, f)
        if self.w_embedded is not None:
            We = W * (self.w_embedded[:, None] * self.w_embedded[None, :] / (w[:, None] * w[None, :]))[None]
            err_e = np.abs(Q - np.einsum("cij,cijq->cq", We, f))
        else:
            err_e = np.full(Q.shape, np.inf)
        bad = ~reg
        nb = int(bad.sum())
        if nb:
            self.n_nonregular += nb
            have = sum(len(a) for a in self.nonregular)
            if have < MAX_NONREGULAR:
                self.nonregular.append(np.stack((U[bad], V[bad]), 1)[:MAX_NONREGULAR - have])
        KJ = np.where(reg, np.abs(K) * J, -1.0).reshape(nc, -1)
        k = KJ.argmax(1)
        ar = np.arange(nc)
        peak = np.stack((U.reshape(nc, -1)[ar, k], V.reshape(nc, -1)[ar, k], KJ[ar, k]), 1)
        return dict(Q=Q, err_e=err_e, mixed=self._mixed(cls, K, H, reg), peak=peak,
                    pmeas=W.sum((1, 2)), sJ=J, sK=K, sH=H, sreg=reg)

    def _mixed(self, cls, K, H, reg):
        """(n,) bool: cells (n, o, o samples) that may meet a class boundary or K = 0."""
        nc = cls.shape[0]
        cls, reg = cls.reshape(nc, -1), reg.reshape(nc, -1)
        anyreg = reg.any(1)
        out = np.where(reg, cls, 99).min(1) != np.where(reg, cls, -99).max(1)

        def widened(A):
            A = A.reshape(nc, -1)
            lo = np.where(reg, A, np.inf).min(1)
            hi = np.where(reg, A, -np.inf).max(1)
            m = STRADDLE_MARGIN * np.where(anyreg, hi - lo, 0.0)
            return lo - m, hi + m

        def meets(lo, hi, *levels):
            return np.any([(lo <= x) & (hi >= x) for x in levels], 0)

        klo, khi = widened(K)
        hlo, hhi = widened(H)
        tk, th = self.tau_K, self.tau_H
        # K = 0 only matters where K changes sign (a kink of |K|); K identically zero (planes,
        # cylinders, cones) has none
        out |= meets(klo, khi, -tk, tk) | ((klo < 0.0) & (khi > 0.0)) \
            | (klo <= tk) & (khi >= -tk) & meets(hlo, hhi, -th, th)
        return anyreg & out

    # -- quadtree -----------------------------------------------------------------------------

    def _tolerance(self, Q):
        """tol_q = rtol max(|Q_q|, ZERO_SCALE scale_q, reference_q) for all quantities, (9,)."""
        A = abs(Q[0])
        scale = np.full(NQ, A)
        scale[2:5] *= self.tau_K
        return self.rtol * np.maximum(np.maximum(np.abs(Q), ZERO_SCALE * scale), self.reference)

    def refine_to(self, depth_limit, point_budget=None):
        """Refine level by level until converged, depth_limit is reached, or (point_budget)
        the next level's children would take the field points evaluated beyond point_budget.
        Only the cells left unaccepted are refined, so the depth grows where the error
        estimates stay large (a singular corner costs four cells a level)."""
        per_cell = self.order * self.order
        while self.active["pid"].size and self.depth < depth_limit:
            self._accept_own()
            a = self.active
            na = a["pid"].size
            if na == 0:
                break
            if point_budget is not None and self.f.n_points + 4 * na * per_cell > point_budget \
                    and self.pending is not None:
                self.budget_spent = True
                break
            ch = _children(a)
            ch.update(self._eval_cells(ch, self._prefetched(1, a.get("row"))))
            self.depth += 1
            # the last level: the depth limit, or the point budget would not hold the next
            # level's children (at most four a cell refined here)
            last = self.depth >= depth_limit or (
                point_budget is not None and self.f.n_points + 16 * na * per_cell > point_budget)
            if last and self.depth < depth_limit:
                self.budget_spent = True
            unit = {k: a[k] for k in ("pid", "s0", "s1", "t0", "t1")}
            unit["Q"] = ch["Q"].reshape(na, 4, NQ).sum(1)
            unit["mixed"] = ch["mixed"].reshape(na, 4).any(1)
            unit["pmeas"] = ch["pmeas"].reshape(na, 4).sum(1)
            pk = ch["peak"].reshape(na, 4, 3)
            unit["peak"] = pk[np.arange(na), pk[:, :, 2].argmax(1)]
            unit["depth"] = np.full(na, self.depth)
            err = _share_area_error(np.abs(a["Q"] - unit["Q"]), unit["Q"])
            mixed = unit["mixed"]
            err_tree = err.copy()
            if self.lines:
                err_tree[mixed, 2:N_SMOOTH] = 0.0  # K integrals of mixed cells: from the lines
            Qtot = sum((p["Q"].sum(0) for p in self.accepted), unit["Q"].sum(0))
            tol = self._tolerance(Qtot)
            budget = tol - self.err_acc
            tree_budget = TREE_SAFETY * budget[:N_SMOOTH]
            if np.all(err_tree[:, :N_SMOOTH].sum(0) <= tree_budget):
                accept = np.ones(na, bool)
            else:
                accept = _greedy_accept(err_tree[:, :N_SMOOTH], tree_budget)
            # refinement driven by the error (point_budget given): a level whose cells may fit
            # the whole budget (the mixed cells' line quantities still to come) is tried as
            # the last one: all its cells are candidates, the mixed ones on lines (above
            # max_depth, those whose interpolant is not yet accurate are split instead of
            # taking lines of the field)
            fit_trial = False
            if point_budget is not None and not last and self.lines:
                hope = err.copy()
                hope[mixed, LINE_Q] = 0.0
                fit_trial = last = bool(np.all(hope.sum(0) <= budget))
            lined = mixed & (accept | last) & self.lines
            split = np.zeros(na, bool)  # mixed cells split for their interpolants' sake
            if lined.any():
                P_tot = sum((p["pmeas"].sum() for p in self.accepted), unit["pmeas"].sum())
                sub = {k: v[lined] for k, v in unit.items()}
                share = self._share(sub["Q"], sub["pmeas"], Qtot, P_tot)
                lbudget = 0.5 * share[:, LINE_Q] * tol[None, LINE_Q]
                interp = self._interpolants(a, ch, lined, sub, lbudget)
                if (not last or (fit_trial and self.depth < self.max_depth)) and not interp["use"].all():
                    # a cell whose interpolant is not yet accurate is split rather than
                    # integrated on lines of the field: its children's interpolants converge
                    # fast, and four children cost less than the lines of one cell
                    keep = interp["use"]
                    split[np.nonzero(lined)[0][~keep]] = True
                    accept[np.nonzero(lined)[0][~keep]] = False
                    lined[lined] = keep
                    sub = {k: v[keep] for k, v in sub.items()}
                    interp = {k: v[keep] for k, v in interp.items()}
                    lbudget = lbudget[keep]
            if lined.any():
                val, lerr, _, charge = self._lines(sub, lbudget, interp)
                if not self.resolve_zero and np.any((self.zero_charge + charge.sum()) * ZERO_CHARGE_PARTS
                                                    > ZERO_CHARGE_SHARE * tol[2:N_SMOOTH]):
                    # the bounds for K = 0 left unresolved would take too much of the K
                    # integrals' tolerance (small K integrals): resolve it from here on
                    self.resolve_zero = True
                    val, lerr, _, charge = self._lines(sub, lbudget, interp)
                # the quadtree's children sums are an independent check of the K integrals:
                # a discrepancy beyond the line estimate that the quadtree also sees (its own
                # estimate) marks a rough or singular integrand the lines did not resolve.
                # Cells on an interpolant have passed a sharper check (the interpolant
                # against samples it was not built from), and there the discrepancy is the
                # Gauss sums' own error at the kink of |K| that the lines remove.
                kq = slice(2, N_SMOOTH)
                gap = np.minimum(np.abs(val[:, :3] - sub["Q"][:, kq]), err[lined, kq])
                gap[interp["use"]] = 0.0
                lerr[:, :3] = np.maximum(lerr[:, :3], gap)
                unit["Q"][lined, LINE_Q] = val
                err[lined, LINE_Q] = lerr
            if fit_trial:  # every cell a candidate but those split for their interpolants
                accept = ~split
            # the candidates again, on every quantity with the lines' errors (global budget)
            c = np.nonzero(accept)[0]
            if c.size and not np.all(err[c].sum(0) <= budget):
                accept[c] = _greedy_accept(err[c], budget)
            unit["err"] = err
            if accept.any():
                self.err_acc = self.err_acc + err[accept].sum(0)
                self.accepted.append({k: v[accept] for k, v in unit.items()})
                if lined.any():
                    self.zero_charge += float(charge[accept[lined]].sum())
            self.pending = {k: v[~accept] for k, v in unit.items()} if last else None
            r4 = np.repeat(~accept, 4)
            self.active = {k: v[r4] for k, v in ch.items()}
            self._record_level()
            if self.progress is not None:
                self.progress(min(1.0, self.depth / float(depth_limit + 1) if point_budget is None
                                  else self.f.n_points / float(point_budget)),
                              "quadrature depth %d: %d of %d cells refined"
                              % (self.depth, int((~accept).sum()), na))

    def _accept_own(self):
        """Accept active cells on their own Gauss sums, without children: cells that meet
        no class boundary (not mixed), all samples regular, whose embedded error estimates
        err_e fit greedily in OWN_SAFETY of the remaining budget of every quantity (the
        class areas' errors: the area's, shared by class fraction, as for children sums)."""
        a = self.active
        n = a["pid"].size
        cand = ~a["mixed"] & a["sreg"].reshape(n, -1).all(1) & np.isfinite(a["err_e"]).all(1)
        if not cand.any():
            return
        err = _share_area_error(a["err_e"].copy(), a["Q"])
        Qtot = sum((p["Q"].sum(0) for p in self.accepted), a["Q"].sum(0))
        budget = OWN_SAFETY * (self._tolerance(Qtot) - self.err_acc)
        ok = np.zeros(n, bool)
        ok[cand] = _greedy_accept(err[cand], budget)
        if not ok.any():
            return
        unit = {k: a[k][ok] for k in ("pid", "s0", "s1", "t0", "t1", "Q", "mixed", "pmeas", "peak")}
        unit["depth"] = np.full(int(ok.sum()), self.depth)
        unit["err"] = err[ok]
        self.err_acc = self.err_acc + unit["err"].sum(0)
        self.accepted.append(unit)
        self.active = {k: v[~ok] for k, v in a.items()}

    @staticmethod
    def _share(Q, pmeas, Qtot, P_tot):
        """Part (n, 9) of each quantity's tolerance that cells with integrals Q (n, 9) and
        parameter areas pmeas (n,) stand for: half by their quantity's share, half by the
        mean of their area and parameter-area shares."""
        with np.errstate(divide="ignore", invalid="ignore"):
            own = np.nan_to_num(np.abs(Q) / np.abs(Qtot)[None, :], nan=0.0, posinf=0.0)
        place = 0.5 * (np.maximum(Q[:, 0], 0.0) / max(abs(Qtot[0]), 1e-300)
                       + pmeas / max(P_tot, 1e-300))
        return 0.5 * (np.minimum(own, 1.0) + place[:, None])

    # -- local interpolants of mixed cells ----------------------------------------------------

    def _interpolants(self, parent, children, sel, units, budget):
        """Tensor interpolants of J, K, H over the mixed parent cells parent[sel], from
        their children's samples, and whether each is accurate enough to stand for the field
        on its lines.

        Interpolants and their errors d_f = max |interpolant - f| at the parent's own nodes
        (cell_interpolant.fit_interpolants). Error of the line integrals taken on the
        interpolant: 2 P max |d(K J)| for the K integrals (P: the cell's parameter measure)
        and, for each class area, A 2 d_g / range_g summed over the class's bounding levels g
        (K = tau_K: elliptic against flat or single; K = -tau_K: saddle against them; H = +-tau_H
        where |K| <= tau_K may hold: flat against single) that the cell's values reach within
        d_g (a level curve moves by about d_g / |grad g|, and |grad g| is about range_g over
        the cell), plus each class's area times max d_J / min J. A cell uses its interpolant when every sample is
        regular and finite and these errors are within INTERPOLANT_SHARE of its budget
        (m, 7); the errors are then part of its line error estimate.

        Returns dict C (m, 3, 2o, 2o), use (m,) bool, err (m, 7)."""
        idx = np.nonzero(sel)[0]
        m = idx.size
        fit = fit_interpolants(parent, children, idx, self._grid_inverse, self._parent_vander)
        d, dKJ, lo, hi, reg = (fit[k] for k in ("d", "dKJ", "lo", "hi", "reg"))
        tk, th = self.tau_K, self.tau_H

        def band(f, lev):
            """Area fraction of the cell within d_f of the level lev of function f."""
            near = (lo[:, f] - d[:, f] <= lev) & (hi[:, f] + d[:, f] >= lev)
            return np.where(near, 2.0 * d[:, f] / np.maximum(hi[:, f] - lo[:, f], 1e-300), 0.0)

        k_plus, k_minus = band(1, tk), band(1, -tk)
        # where |K| <= tau_K may hold, |H| = tau_H separates flat from single
        low_K = (lo[:, 1] - d[:, 1] <= tk) & (hi[:, 1] + d[:, 1] >= -tk)
        h_band = np.where(low_K, band(2, th) + band(2, -th), 0.0)
        flat_ok = (lo[:, 2] - d[:, 2] <= th) & (hi[:, 2] + d[:, 2] >= -th)
        single_ok = (hi[:, 2] + d[:, 2] > th) | (lo[:, 2] - d[:, 2] < -th)
        A = np.abs(units["Q"][:, 0])
        err = np.empty((m, N_LINE_Q))
        err[:, :3] = (2.0 * units["pmeas"] * dKJ)[:, None]
        # columns flat, single, elliptic, saddle: K = +tau_K borders elliptic, K = -tau_K
        # saddle, both border flat or single (whichever |H| allows), H = +-tau_H both
        err[:, 3] = A * (np.where(flat_ok, k_plus + k_minus, 0.0) + h_band)
        err[:, 4] = A * (np.where(single_ok, k_plus + k_minus, 0.0) + h_band)
        err[:, 5] = A * k_plus
        err[:, 6] = A * k_minus
        # and the interpolated J itself, in each class's area
        rel_J = d[:, 0] / np.maximum(np.abs(lo[:, 0]), 1e-300)
        err[:, 3:] += np.abs(units["Q"][:, N_SMOOTH:]) * rel_J[:, None]
        err = np.where(reg[:, None], err, np.inf)
        use = np.all(err <= INTERPOLANT_SHARE * budget, 1)
        return dict(C=fit["C"], use=use, err=np.where(use[:, None], err, 0.0))

    def _segments_t(self, cell, pid, sig):
        """SegmentField of the lines sigma = sig (L,) of patches pid (L,) in the mixed cells
        cell (L,), and the lines' strip widths hi - lo (L,) (the constant of turned cells:
        _turned); the field is evaluated where no interpolant is used."""
        u, _ = self.patches.u_of_sigma(pid, sig)
        lo, hi = self.patches.bounds(pid, u)
        width = self._turned(cell, hi - lo, "width")
        evalf = SegmentField(self._interp["C"], self._interp["use"], self._pc_cells, cell, sig, "t",
                             lambda x, i: self.f(u[i], lo[i] + x * width[i]))
        return evalf, width

    def _cell_field(self, cell, sig, t):
        """J, K, H, regular (m,) at patch coordinates (sig, t) (m,) of the mixed cells cell
        (m,) (indices into _pc_cells): the interpolant where the cell uses one, else the field."""
        cells, interp = self._pc_cells, self._interp
        cell = np.asarray(cell).ravel()
        sig, t = np.broadcast_to(sig, cell.shape).ravel(), np.broadcast_to(t, cell.shape).ravel()
        J, K, H = np.empty(cell.size), np.empty(cell.size), np.empty(cell.size)
        reg = np.ones(cell.size, bool)
        use = interp["use"][cell]
        i = np.nonzero(use)[0]
        if i.size:
            J[i], K[i], H[i] = cell_values(interp["C"], cells, cell[i], sig[i], t[i])
        i = np.nonzero(~use)[0]
        if i.size:
            pid = cells["pid"][cell[i]]
            u, _ = self.patches.u_of_sigma(pid, sig[i])
            lo, hi = self.patches.bounds(pid, u)
            J[i], K[i], H[i], reg[i] = self.f(u, lo + t[i] * (hi - lo))
        return J, K, H, reg

    # -- lines in mixed cells -----------------------------------------------------------------

    def _crossings(self, evalf, refine=True):
        """Zeros of the five level functions along the segments of evalf, x in [x0, x1] (n,)
        (evalf.x0, evalf.x1).

        evalf(x, i) -> (J, K, H, regular) (m,) each, at parameters x (m,) of segments i (m,),
        and evalf.samples(zs) at the fractions zs (k,) of every segment (a SegmentField).
        Brackets: sign changes between the samples at ZS, and, where three samples of one
        sign dip towards zero and their parabola's vertex gets within DIP_FRACTION of zero,
        the two sides of the extremum (_parabolic_min) when it has the other sign. Levels of
        H only matter where |K| <= tau_K and are skipped elsewhere. The brackets are refined
        together (one field call per step of solve_bracketed). refine=False only counts crossings
        (approximate positions from the samples, no further field calls). Returns segment
        index (k,), level index (k,), x (k,), and the samples: dict of (n, 9) arrays J,
        KJ (K J; both 0 where not regular), K, H, reg, and zero (n,): K changes sign on the
        segment by the samples (a sign change, or a dip of K towards zero). Crossings of K = 0
        (level 4) are refined and returned only while resolve_zero is set (see _line_values).
        refine may also be an (n,) bool array: per segment."""
        x0, x1 = evalf.x0, evalf.x1
        n = x0.size
        refine = np.broadcast_to(np.asarray(refine, bool), (n,))
        m = ZS.size
        xs = x0[:, None] + (x1 - x0)[:, None] * ZS[None, :]
        J, K, H, reg = evalf.samples(ZS)
        G = self._thresholds(K, H)
        KJ = K * J
        every = reg.all()  # the usual case: the masks below change nothing
        if not every:
            G[~reg] = np.nan
            J, KJ = np.where(reg, J, 0.0), np.where(reg, KJ, 0.0)
        G = G.reshape(n, m, N_LEVELS)
        S = dict(J=J.reshape(n, m), KJ=KJ.reshape(n, m), K=K.reshape(n, m), H=H.reshape(n, m),
                 reg=reg.reshape(n, m))
        near = (np.abs(K if every else np.where(reg, K, np.inf)) <= self.tau_K).reshape(n, m)  # H matters
        pos = G > 0.0
        change = pos[:, :-1] != pos[:, 1:]
        if not (every and np.isfinite(K).all() and np.isfinite(H).all()):
            fin = np.isfinite(G)
            change &= fin[:, :-1] & fin[:, 1:]
        k_change = change[:, :, :2].any(2) | change[:, :, 4]
        h_ok = near[:, :-1] | near[:, 1:] | k_change
        change[:, :, 2:4] &= h_ok[:, :, None]
        S["zero"] = change[:, :, 4].any(1)  # K changes sign between samples
        change[:, :, 4] &= self.resolve_zero
        li, j, q = np.nonzero(change)
        a, b, fa, fb = xs[li, j], xs[li, j + 1], G[li, j, q], G[li, j + 1, q]

        def g(x, idx, seg, lev):
            _, Kx, Hx, rx = evalf(x, seg[idx])
            return np.where(rx, self._thresholds(Kx, Hx)[np.arange(idx.size), lev[idx]], np.nan)

        # two crossings between neighbouring samples: a dip of one sign towards zero
        g0, g1, g2 = G[:, :-2], G[:, 1:-1], G[:, 2:]
        with np.errstate(invalid="ignore", divide="ignore"):
            same = np.sign(G)  # of neighbouring samples, each sign and size taken once
            same = same[:, :-1] == same[:, 1:]
            size = np.abs(G)
            dip = same[:, :-1] & same[:, 1:] & (size[:, 1:-1] < size[:, :-2]) & (size[:, 1:-1] < size[:, 2:])
            dip[:, :, 2:4] &= (near[:, :-2] | near[:, 1:-1] | near[:, 2:])[:, :, None]
            pi, pj, pq = np.nonzero(dip)
            x_0, x_1, x_2 = xs[pi, pj], xs[pi, pj + 1], xs[pi, pj + 2]
            y0, y1, y2 = g0[pi, pj, pq], g1[pi, pj, pq], g2[pi, pj, pq]
            d01, d12 = (y1 - y0) / (x_1 - x_0), (y2 - y1) / (x_2 - x_1)
            c2 = (d12 - d01) / (x_2 - x_0)
            c1 = d01 - c2 * (x_0 + x_1)
            xv = -c1 / (2.0 * c2)
            vert = (y1 - c2 * x_1 ** 2 - c1 * x_1) - c1 * c1 / (4.0 * c2)
        sg = np.sign(y1)
        cand = np.nonzero(sg * vert < DIP_FRACTION * np.abs(y1))[0]
        # K dipping towards zero may change sign twice between samples: searched only while
        # K = 0 is resolved
        z4 = pq[cand] == 4
        S["zero"][pi[cand[z4]]] = True
        if not self.resolve_zero:
            cand = cand[~z4]
        # segments only counted: every dip whose parabola's vertex is beyond zero, the
        # parabola's roots for its two crossings
        with np.errstate(invalid="ignore", divide="ignore"):
            cross = np.nonzero(~refine[pi] & (sg * vert < 0.0) & (self.resolve_zero | (pq != 4)))[0]
            half = np.sqrt(np.maximum(-vert[cross] / c2[cross], 0.0))
        counted = (pi[cross], pq[cross], np.concatenate((xv[cross] - half, xv[cross] + half)))
        cand = cand[refine[pi[cand]]]
        if cand.size:
            pi, pq, sg = pi[cand], pq[cand], sg[cand]
            lo_, hi_ = x_0[cand], x_2[cand]
            xe, fe = _parabolic_min(lambda x, idx: sg[idx] * g(x, idx, pi, pq),
                                    np.stack((lo_, x_1[cand], hi_), 1),
                                    sg[:, None] * np.stack((y0[cand], y1[cand], y2[cand]), 1))
            hit = np.nonzero(fe < 0.0)[0]
            fe = sg[hit] * fe[hit]
            li = np.concatenate((li, pi[hit], pi[hit]))
            q = np.concatenate((q, pq[hit], pq[hit]))
            a = np.concatenate((a, lo_[hit], xe[hit]))
            b = np.concatenate((b, xe[hit], hi_[hit]))
            fa = np.concatenate((fa, y0[cand][hit], fe))
            fb = np.concatenate((fb, fe, y2[cand][hit]))
        roots = np.empty(li.size)
        # segments only counted: regula falsi positions in their sign-change brackets
        fixed = ~refine[li]
        i = np.nonzero(fixed)[0]
        if i.size:
            with np.errstate(invalid="ignore", divide="ignore"):
                roots[i] = a[i] + fa[i] / (fa[i] - fb[i]) * (b[i] - a[i])
        # on an interpolant's segment a level function is a polynomial: Newton on its
        # power series; elsewhere bracketed steps on the field
        poly = evalf.use[li] & ~fixed
        i = np.nonzero(poly)[0]
        if i.size:
            roots[i] = evalf.roots(li[i], LEVEL_ROW[q[i]], self.level_offset[q[i]], a[i], b[i],
                                   fa[i], fb[i], 2.0 * CROSSING_RTOL)
        i = np.nonzero(~poly & ~fixed)[0]
        if i.size:
            roots[i] = solve_bracketed(lambda x, k: g(x, i[k], li, q), a[i], b[i], fa[i], fb[i],
                                       CROSSING_RTOL * (x1 - x0)[li[i]], maxiter=CROSSING_STEPS)
        li = np.concatenate((li, counted[0], counted[0]))
        q = np.concatenate((q, counted[1], counted[1]))
        return li, q, np.concatenate((roots, counted[2])), S

    def _line_values(self, cell, pid, sig, t0, t1, n_counted=0):
        """Lines sigma = const of patches pid over t in [t0, t1] (all (L,)), in the mixed
        cells cell (L,) (indices into _pc_cells); the last n_counted of them are not
        integrated: their crossings are only counted (_crossings with refine False; their
        F, E, C are zero).

        Returns dict F (L, 7) integrals of the LINE_Q integrands times (hi - lo) dt, E (L, 7)
        their error estimates, C (L,) the bound charged to E's |K| column for sign changes
        of K left unresolved (below; half of it to K+ and K-), count (L, 5) crossings of each
        level, pair (L, 5, 2) the closest two crossings of each level (NaN when fewer than
        two), ends (L, 5, 2) the first and last crossing of each level (_count_and_pairs). The pieces of a line between crossings have the class and the sign of K of
        their midpoint; unless resolve_zero is set, K = 0 does not cut the lines, and flat
        and single pieces take the sign of their K integral instead. On lines of an
        interpolant J and K J are integrated exactly (SegmentField.integrals, no error
        estimate of their own); on lines of the field by Gauss-Kronrod 3/7 on pieces longer
        than SHORT_PIECE of the line (error
        estimate: the difference to the integral of their degree-8 interpolants at the
        samples ZS; a line without crossings is one piece whose Kronrod nodes are samples),
        over those interpolants on shorter ones (error estimate: against the degree-6
        interpolants at the inner samples)."""
        L = pid.size
        evalf, width = self._segments_t(cell, pid, sig)
        nv = L - n_counted  # lines integrated
        li, lq, roots, S = self._crossings(evalf, refine=np.arange(L) < nv)
        counts = _count_and_pairs(li, lq, roots, L)
        v = li < nv
        ar = np.arange(nv)
        lid, a, b = _segments(np.concatenate((t0[:nv], roots[v], t1[:nv])), np.concatenate((ar, li[v], ar)))
        span = (t1 - t0)[lid]
        # pieces on an interpolant's line: exact integrals of its series, class at the midpoint
        poly = evalf.use[lid]
        whole = (a == t0[lid]) & (b == t1[lid]) & ~poly  # no crossing: the samples hold the nodes
        long_ = ((b - a) > SHORT_PIECE * span) & ~whole & ~poly
        nl, nw = int(long_.sum()), int(whole.sum())
        # one field call: the Kronrod nodes of long pieces, the midpoints of short ones and
        # of the interpolant's pieces
        tl = a[long_, None] + (b - a)[long_, None] * XK[None, :]
        sh = ~long_ & ~whole & ~poly
        mp = sh | poly
        tq = np.concatenate((tl.ravel(), 0.5 * (a + b)[mp]))
        lq_ = np.concatenate((np.repeat(lid[long_], XK.size), lid[mp]))
        J, K, H, reg = evalf(tq, lq_)
        # node values of long and whole pieces (7 each), then the other pieces' midpoints
        inner = (lid[whole], slice(1, -1))
        J = np.concatenate((np.where(reg, J, 0.0)[:nl * XK.size], S["J"][inner].ravel(),
                            np.where(reg, J, 0.0)[nl * XK.size:]))
        Kc = np.concatenate((K[:nl * XK.size], S["K"][inner].ravel(), K[nl * XK.size:]))
        Hc = np.concatenate((H[:nl * XK.size], S["H"][inner].ravel(), H[nl * XK.size:]))
        rc = np.concatenate((reg[:nl * XK.size], S["reg"][inner].ravel(), reg[nl * XK.size:]))
        KJ = np.where(rc, Kc * J, 0.0)
        mid = np.empty(lid.size, int)  # index of each piece's midpoint value
        kw = np.concatenate((np.nonzero(long_)[0], np.nonzero(whole)[0]))
        mid[kw] = np.arange(nl + nw) * XK.size + XK.size // 2
        mid[mp] = (nl + nw) * XK.size + np.arange(int(mp.sum()))
        cls = classify(Kc[mid], Hc[mid], self.tau_H, self.tau_K, rc[mid])
        vals = np.zeros((2, lid.size))
        errs = np.zeros((2, lid.size))
        if poly.any():
            k = np.nonzero(poly)[0]
            vals[:, k] = np.stack(evalf.integrals(lid[k], a[k], b[k])) * width[lid[k]]
        fk = np.nonzero(~poly)[0]
        if fk.size:
            # pieces on the field: integrals of the interpolants at the line's samples ZS
            lf = lid[fk]
            LV = legendre_vander
            dz = 0.5 * (LV(2.0 * (b[fk] - t0[lf]) / span[fk] - 1.0, ZS.size)
                        - LV(2.0 * (a[fk] - t0[lf]) / span[fk] - 1.0, ZS.size))
            w_hi = (dz @ M_HI) * (span[fk] * width[lf])[:, None]
            w_lo = (dz[:, :ZS.size - 1] @ M_LO) * (span[fk] * width[lf])[:, None]
            at = np.empty(lid.size, int)  # row in the field pieces' arrays
            at[fk] = np.arange(fk.size)
            ikw, ish = at[kw], at[sh]
            scale = (b[kw] - a[kw]) * width[lid[kw]]
            for row, (f, Z) in enumerate(((J, S["J"]), (KJ, S["KJ"]))):
                fz = Z[lf]
                interp = np.einsum("sm,sm->s", w_hi, fz)
                # long and whole pieces: Kronrod value, error estimated against the interpolant
                vk = (f[:(nl + nw) * XK.size].reshape(nl + nw, XK.size) @ WK) * scale
                vals[row, kw] = vk
                errs[row, kw] = np.abs(vk - interp[ikw])
                # short pieces: the interpolant, against the degree-6 one
                vals[row, sh] = interp[ish]
                errs[row, sh] = np.abs(interp[ish] - np.einsum("sm,sm->s", w_lo[ish], fz[ish, 1:-1]))
        sk = np.sign(np.where(cls >= 0, Kc[mid], 0.0))
        charge = np.zeros(lid.size)
        if not self.resolve_zero:
            # K = 0 not resolved: a flat or single piece (|K| <= tau_K on it) takes the sign of
            # its K integral; on a line where K changes sign, its K integrals' error is at most
            # B A - |int K J| (|K|) and half that (K+, K-), B the bound of |K| on it (tau_K,
            # or ZERO_BOUND_SAFETY times the line's largest sampled |K| when less), A its area
            soft = (cls == 0) | (cls == 1)
            sk = np.where(soft, np.sign(vals[1]), sk)
            i = np.nonzero(soft & S["zero"][lid])[0]
            if i.size:
                kmax = np.where(S["reg"], np.abs(S["K"]), 0.0).max(1)
                bound = np.minimum(self.tau_K, ZERO_BOUND_SAFETY * kmax[lid[i]])
                charge[i] = np.maximum(bound * vals[0, i] - np.abs(vals[1, i]), 0.0)
        # per piece: |K| J, max(K,0) J, max(-K,0) J, then J into its class column
        P = np.zeros((lid.size, N_LINE_Q))
        Pe = np.zeros((lid.size, N_LINE_Q))
        for col, fac in ((0, sk), (1, np.maximum(sk, 0.0)), (2, np.minimum(sk, 0.0))):
            P[:, col] = fac * vals[1]
            Pe[:, col] = np.abs(fac) * errs[1] + ZERO_CHARGE_PARTS[col] * charge
        ok = cls >= 0
        rows = np.nonzero(ok)[0]
        P[rows, 3 + cls[ok]] = vals[0][ok]
        Pe[rows, 3 + cls[ok]] = errs[0][ok]
        F, E = np.zeros((L, N_LINE_Q)), np.zeros((L, N_LINE_Q))
        F += _row_sums(lid, P, L)
        E += _row_sums(lid, Pe, L)
        out = dict(F=F, E=E, C=np.bincount(lid, weights=charge, minlength=L), power=evalf.power)
        out.update(counts)
        return out

    def _piece_values(self, pc, counted=True):
        """Gauss-Kronrod 3/7 in sigma over pieces pc (dict of (n,) cell, sa, sb, kind) of the
        mixed cells _pc_cells; nodes cluster_map(kind) of XI9: the Kronrod nodes, and (with
        counted) lines next to both ends whose crossings are only counted, to detect
        tangencies there (in the same _line_values call).
        Slivers (pieces without clustered ends narrower than SLIVER of their cell, between
        nearby kinks such as the crossings of K = -tau_K, 0, tau_K) take the 2-point Gauss
        rule instead, with its difference to the midpoint rule as the sigma error, and no
        tangency search: three lines instead of nine.

        Returns values (n, 7), sigma error (_kronrod_error) (n, 7), t error (n, 7), its
        charged part (the lines' C, _line_values) (n,), and of the 9 lines: sigma (n, 9),
        count (n, 9, 5), pair (n, 9, 5, 2) (for slivers count 0 and pair NaN: no tangency
        cut), the first and last crossing of each level, ends (n, 9, 5, 2) (NaN where none),
        and the power series in t of the lines on interpolants (SegmentField.power)
        (n, 9, 3, d + 1) (without counted, those of the end lines are 0, NaN, NaN and 0)."""
        cells = self._pc_cells
        n, m = pc["sa"].size, XI9.size
        cw = (cells["s1"] - cells["s0"])[pc["cell"]]
        sliver = ((pc["sb"] - pc["sa"]) < SLIVER * cw) & (pc["kind"] == 0)
        nk = np.nonzero(~sliver)[0]
        ns = np.nonzero(sliver)[0]
        c, dc = cluster_map(np.repeat(pc["kind"][nk, None], m, 1), np.broadcast_to(XI9, (nk.size, m)))
        w = (pc["sb"] - pc["sa"])[:, None]
        sig = np.repeat(pc["sa"][:, None], m, 1) + w * XI9[None, :]
        sig[nk] = pc["sa"][nk, None] + w[nk] * c
        # lines: the Kronrod nodes of the pieces, then the three nodes of the slivers, then
        # (counted only) the two end lines of the pieces
        sl = pc["sa"][ns, None] + w[ns] * XI3[None, :]
        ends = sig[nk][:, [0, -1]].ravel() if counted else np.empty(0)
        ecell = np.repeat(pc["cell"][nk], 2) if counted else np.empty(0, int)
        lsig = np.concatenate((sig[nk, 1:-1].ravel(), sl.ravel(), ends))
        lcell = np.concatenate((np.repeat(pc["cell"][nk], m - 2), np.repeat(pc["cell"][ns], XI3.size), ecell))
        lpid = cells["pid"][lcell]
        nv = lsig.size - ends.size
        _, ldu = self.patches.u_of_sigma(lpid[:nv], lsig[:nv])
        ldu = self._turned(lcell[:nv], ldu, "du")
        d = self._line_values(lcell, lpid, lsig, cells["t0"][lcell], cells["t1"][lcell], n_counted=ends.size)
        nkl = nk.size * (m - 2)
        Fk, es, et = (np.zeros((n, N_LINE_Q)) for _ in range(3))
        Fc = np.zeros(n)
        if nk.size:
            wt = (w[nk] * dc[:, 1:-1] * ldu[:nkl].reshape(nk.size, m - 2))[:, :, None]
            F = d["F"][:nkl].reshape(nk.size, m - 2, N_LINE_Q) * wt
            Fk[nk] = np.einsum("nkq,k->nq", F, WK)
            es[nk] = kronrod_error(F, Fk[nk])
            et[nk] = np.einsum("nkq,k->nq", d["E"][:nkl].reshape(nk.size, m - 2, N_LINE_Q) * wt, WK)
            Fc[nk] = (d["C"][:nkl].reshape(nk.size, m - 2) * wt[:, :, 0]) @ WK
        if ns.size:
            wt = (w[ns] * ldu[nkl:nv].reshape(ns.size, XI3.size))[:, :, None]
            F = d["F"][nkl:nv].reshape(ns.size, XI3.size, N_LINE_Q) * wt
            Fk[ns] = 0.5 * (F[:, 0] + F[:, 2])
            es[ns] = np.abs(Fk[ns] - F[:, 1])
            et[ns] = 0.5 * (d["E"][nkl:nv].reshape(ns.size, XI3.size, N_LINE_Q) * wt)[:, [0, 2]].sum(1)
            Fc[ns] = 0.5 * (d["C"][nkl:nv].reshape(ns.size, XI3.size) * wt[:, :, 0])[:, [0, 2]].sum(1)
        count = np.zeros((n, m, N_LEVELS), int)
        pair = np.full((n, m, N_LEVELS, 2), np.nan)
        ends = np.full((n, m, N_LEVELS, 2), np.nan)
        series = np.zeros((n, m) + d["power"].shape[1:])  # of the lines on interpolants
        if nk.size:
            count[nk, 1:-1] = d["count"][:nkl].reshape(nk.size, m - 2, -1)
            pair[nk, 1:-1] = d["pair"][:nkl].reshape(nk.size, m - 2, N_LEVELS, 2)
            ends[nk, 1:-1] = d["ends"][:nkl].reshape(nk.size, m - 2, N_LEVELS, 2)
            series[nk, 1:-1] = d["power"][:nkl].reshape((nk.size, m - 2) + series.shape[2:])
        if nk.size and counted:
            e = {k: d[k][nv:] for k in ("count", "pair", "ends", "power")}
            count[nk, 0], count[nk, -1] = e["count"][0::2], e["count"][1::2]
            pair[nk, 0], pair[nk, -1] = e["pair"][0::2], e["pair"][1::2]
            ends[nk, 0], ends[nk, -1] = e["ends"][0::2], e["ends"][1::2]
            series[nk, 0], series[nk, -1] = e["power"][0::2], e["power"][1::2]
        return Fk, es, et, Fc, sig, count, pair, ends, series

    def _edge_cuts(self, cells):
        """sigma (k,) where level curves cross the cells' edges t = t0 and t = t1, and the
        cell (k,) of each: the line values have a kink there."""
        pid = cells["pid"]
        n = pid.size
        E = np.concatenate((np.arange(n), np.arange(n)))
        h = INSIDE * (cells["t1"] - cells["t0"])
        tE = np.concatenate((cells["t0"] + h, cells["t1"] - h))

        pe = pid[E]

        def fallback(x, i):  # edge lines t = tE of the cells, sigma = x
            u, _ = self.patches.u_of_sigma(pe[i], x)
            lo, hi = self.patches.bounds(pe[i], u)
            return self.f(u, lo + tE[i] * (hi - lo))

        evalf = SegmentField(self._interp["C"], self._interp["use"], cells, E, tE, "sigma", fallback)
        li, _, roots, _ = self._crossings(evalf)
        return E[li], roots

    def _tangent_cuts(self, pc, sig, count, pair, series):
        """sigma (k,) and piece (k,) where a level curve is tangent to the lines sigma =
        const, between neighbouring lines of a piece whose crossing counts differ.

        With h = s g_q (s the sign making h < 0 between the closest crossing pair on the
        line with more crossings), phi(sigma) = min of h along the line over a window about
        that pair (on an interpolant's line from its series, SegmentField.window_min; on the
        field by _parabolic_min) has a simple root at the tangency. Where phi changes sign
        between the lines, the tangency is found on an interpolant by Newton's method on
        g = dg/dt = 0 (cell_interpolant.tangency_points), else (and where Newton fails) by
        solve_bracketed on phi. Brackets where phi does not change sign, and roots at a
        piece's end (within EDGE_XI of its width), give no cut."""
        p, j, q = np.nonzero(count[:, :-1, :] != count[:, 1:, :])
        if p.size == 0:
            return p, np.empty(0)
        more = np.where(count[p, j, q] > count[p, j + 1, q], j, j + 1)
        ta, tb = pair[p, more, q, 0], pair[p, more, q, 1]
        keep = np.isfinite(ta)
        p, j, q, more, ta, tb = p[keep], j[keep], q[keep], more[keep], ta[keep], tb[keep]
        if p.size == 0:
            return p, np.empty(0)
        cells = self._pc_cells
        cell = pc["cell"][p]
        t0, t1 = cells["t0"][cell], cells["t1"][cell]
        gap = tb - ta
        w0 = np.maximum(ta - gap, t0)
        w1 = np.minimum(tb + gap, t1)

        def level(sg, t, i):
            _, K, H, reg = self._cell_field(cell[i], sg, t)
            return np.where(reg, self._thresholds(K, H)[np.arange(i.size), q[i]], np.nan)

        sm = sig[p, more]
        sign = -np.sign(level(sm, 0.5 * (ta + tb), np.arange(p.size)))

        use = self._interp["use"][cell]
        row, offset = LEVEL_ROW[q], self.level_offset[q]

        def phi(sg, i, line=None):
            """min over the window of sign * g_q on the lines sg: on an interpolant's line
            from its series in t (the piece's line line when given, else made here), else
            by parabolic steps."""
            out = np.empty(i.size)
            k = np.nonzero(use[i])[0]
            if k.size:
                ik = i[k]
                if line is None:
                    seg = SegmentField(self._interp["C"], self._interp["use"], cells, cell[ik], sg[k], "t", None)
                    out[k] = seg.window_min(row[ik], offset[ik], sign[ik], w0[ik], w1[ik])
                else:
                    c0, c1 = cells["t0"][cell[ik]], cells["t1"][cell[ik]]
                    out[k] = window_min_of(series[p[ik], line[k], row[ik]], offset[ik], sign[ik],
                                           _local(w0[ik], c0, c1), _local(w1[ik], c0, c1))
            k = np.nonzero(~use[i])[0]
            if k.size:
                ik, sk = i[k], sg[k]
                x3 = np.stack((w0[ik], 0.5 * (ta + tb)[ik], w1[ik]), 1)
                f3 = np.repeat(sign[ik], 3) * level(np.repeat(sk, 3), x3.ravel(), np.repeat(ik, 3))
                out[k] = _parabolic_min(lambda t, m: sign[ik[m]] * level(sk[m], t, ik[m]), x3,
                                        f3.reshape(-1, 3))[1]
            return out

        other = np.where(more == j, j + 1, j)
        so = sig[p, other]
        ar = np.arange(p.size)
        fm, fo = phi(sm, ar, more), phi(so, ar, other)
        ok = (fm < 0.0) & (fo > 0.0)
        if not ok.any():
            return p[:0], np.empty(0)
        i = np.nonzero(ok)[0]
        w = (pc["sb"] - pc["sa"])[p[i]]
        # on an interpolant: Newton on g = dg/dt = 0 from the closer pair's midpoint; the
        # bracketed search on phi where that fails, and on the field
        root = np.full(i.size, np.nan)
        k = np.nonzero(use[i])[0]
        if k.size:
            ik = i[k]
            root[k] = tangency_points(self._interp["C"], cells, cell[ik], row[ik], offset[ik], sm[ik], so[ik],
                                      w0[ik], w1[ik], sm[ik], 0.5 * (ta + tb)[ik], TANGENT_RTOL * w[k])
        k = np.nonzero(np.isnan(root))[0]
        if k.size:
            root[k] = solve_bracketed(lambda x, m: phi(x, i[k[m]]), sm[i[k]], so[i[k]], fm[i[k]], fo[i[k]],
                                      TANGENT_RTOL * w[k], maxiter=TANGENT_STEPS)
        inside = _inside_pieces(pc, p[i], root)
        return p[i][inside], root[inside]

    def _corner_cuts(self, pc, sig, count, ends, series):
        """sigma (k,) and piece (k,) where a level curve of H (H = +-tau_H) meets one of K
        (K = +-tau_K) inside a piece on an interpolant: a corner of the flat region, where
        the class areas' line integrals have a kink in sigma (the flat part of the band
        |K| <= tau_K begins or ends).

        Along a crossing of K = +-tau_K that every line of the piece has (the same count,
        one or two, on all of them: its first and last crossing, ends), psi = g_H at that
        crossing (H - tau_H or H + tau_H, from the line's power series) changes sign between
        neighbouring lines where the curves meet; that corner is found by Newton's method on
        the pair of level equations on the interpolant (level_intersections), from the point
        between the lines where psi interpolates to zero, and kept when it lies between
        them. Corners Newton does not find, and corners on lines of the field, give no cut."""
        cells = self._pc_cells
        cell = pc["cell"]
        deg = series.shape[-1] - 1
        # pieces on an interpolant, K levels (0, 1) crossed as often (once or twice) on all
        # of their lines, and whether a second crossing is there
        ck = count[:, :, :2]
        ok = self._interp["use"][cell][:, None] & np.all(ck == ck[:, :1], 1) & (ck[:, 0] >= 1) & (ck[:, 0] <= 2)
        ok = np.stack((ok, ok & (ck[:, 0] == 2)), -1)  # (n, K level, first or last crossing)
        p = np.nonzero(ok.any((1, 2)))[0]
        if p.size == 0:
            return p, np.empty(0)
        tk = ends[p][:, :, :2, :]  # (m, 9 lines, K level, end)
        z = _local(tk, cells["t0"][cell[p], None, None, None], cells["t1"][cell[p], None, None, None])
        Hs = np.repeat(series[p, :, 2, None, :], 4, axis=2)  # each line's H series, for its 4 crossings
        H = horner(Hs.reshape(-1, deg + 1), z.reshape(-1)).reshape(tk.shape)
        # psi (m, 9, K level, end, H level): g_H at the K crossings, its sign changes between lines
        psi = H[..., None] - self.level_offset[2:4]
        pos = psi > 0.0
        fin = np.isfinite(psi)
        change = (pos[:, :-1] != pos[:, 1:]) & fin[:, :-1] & fin[:, 1:] & ok[p][:, None, :, :, None]
        i, j, qk, e, h = np.nonzero(change)
        if i.size == 0:
            return i, np.empty(0)
        qh = h + 2
        pa, pb = psi[i, j, qk, e, h], psi[i, j + 1, qk, e, h]
        frac = pa / (pa - pb)  # where psi interpolates to zero between the lines
        p = p[i]
        sa, sb = sig[p, j], sig[p, j + 1]
        s_start = sa + frac * (sb - sa)
        t_start = tk[i, j, qk, e] + frac * (tk[i, j + 1, qk, e] - tk[i, j, qk, e])
        c = cell[p]
        root = level_intersections(self._interp["C"], cells, c, LEVEL_ROW[qh], self.level_offset[qh],
                                   LEVEL_ROW[qk], self.level_offset[qk], sa, sb, cells["t0"][c], cells["t1"][c],
                                   s_start, t_start, TANGENT_RTOL * (pc["sb"] - pc["sa"])[p])
        inside = _inside_pieces(pc, p, root)
        return p[inside], root[inside]

    def _island_cuts(self, pc, F):
        """sigma (k,) and piece (k,) through islands of a class inside cells on an
        interpolant that none of the cell's lines meets (first level: the pieces pc cover
        their cells; F (n, 7) their line integrals): where the lines find no elliptic part
        but the interpolant's K may exceed tau_K (its Bernstein bounds,
        cell_interpolant.interpolant_range), or no saddle part and K may fall below -tau_K,
        or only one of them and no band |K| <= tau_K while K may enter it, the extremum of K
        is searched (interpolant_extremum); where it lies beyond the level, the piece through
        it is cut at its sigma, so that the next level's lines next to the cut cross the
        island (and find its tangencies)."""
        cells = self._pc_cells
        use = self._interp["use"]
        nc = use.size
        area = _row_sums(pc["cell"], F[:, 3:], nc)  # flat, single, elliptic, saddle
        ell, sad, band = area[:, 2] > 0.0, area[:, 3] > 0.0, area[:, 0] + area[:, 1] > 0.0
        tk = self.tau_K
        c = np.nonzero(use & ~(ell & sad & band))[0]
        if c.size == 0:
            return np.empty(0, int), np.empty(0)
        lo, hi = interpolant_range(self._interp["C"], c, 1)
        # the largest K (sign 1) or the least (-1) where the lines miss a part that the bounds
        # allow: beyond tau_K (elliptic), below -tau_K (saddle), into the band from above or
        # below (only elliptic or only saddle on the lines); one search for all of them
        searches = [(c[m], sign, bound, strict) for m, sign, bound, strict in (
            (~ell[c] & (hi > tk), 1.0, tk, True), (~sad[c] & (lo < -tk), -1.0, tk, True),
            (~band[c] & ell[c] & ~sad[c] & (lo <= tk), -1.0, -tk, False),
            (~band[c] & sad[c] & ~ell[c] & (hi >= -tk), 1.0, -tk, False)) if m.any()]
        if not searches:
            return np.empty(0, int), np.empty(0)
        cell = np.concatenate([a[0] for a in searches])
        sign, bound, strict = (np.concatenate([np.full(a[0].size, a[i]) for a in searches]) for i in (1, 2, 3))
        val, x, _ = interpolant_extremum(self._interp["C"], cell, 1, sign)
        hit = np.where(strict, val > bound, val >= bound)
        cell, x = cell[hit], x[hit]
        if cell.size == 0:
            return np.empty(0, int), np.empty(0)
        at = cells["s0"][cell] + 0.5 * (x + 1.0) * (cells["s1"][cell] - cells["s0"][cell])
        # the piece of each cell that holds the point, away from its ends
        i, p = np.nonzero(pc["cell"][None, :] == cell[:, None])
        inside = _inside_pieces(pc, p, at[i])
        return p[inside], at[i][inside]

    def _turn_cells(self, cells, interpolants):
        """The mixed cells with their lines turned where that suits the level curves: a cell
        on its interpolant, in a patch whose map to (u, v) is affine (linear in sigma, constant
        strip bounds: the area element du/dsigma (hi - lo) is one constant), along which K
        varies more in sigma than in t (the level curves run along t, so lines sigma = const
        would meet them at small angles and cross the cell's t edges, each crossing a cut) is
        given with sigma and t exchanged: the box, its interpolant's axes, and the constant
        width and du/dsigma of the original in "width" and "du" (NaN for the others, see
        _turned). The line integrals of a cell do not depend on the direction of its lines."""
        n = cells["pid"].size
        P = self.patches
        pid = cells["pid"]
        affine = (P.umap[pid] == 0) & (P.lo_piece[pid] < 0) & (P.hi_piece[pid] < 0)
        cand = np.nonzero(interpolants["use"] & affine)[0]
        turn = np.zeros(n, bool)
        if cand.size:
            # mean |dK| along each local axis from the K series: sum over the other axis of
            # |coefficients| times the derivative sizes of P_a (a (a + 1) / 2 at the ends)
            Ck = np.abs(interpolants["C"][cand, 1])
            dsize = np.arange(Ck.shape[-1]) * (np.arange(Ck.shape[-1]) + 1) / 2.0
            d_sigma = (Ck.sum(2) * dsize).sum(1)
            d_t = (Ck.sum(1) * dsize).sum(1)
            turn[cand] = d_sigma > d_t
        cells = dict(cells)
        cells["width"] = np.full(n, np.nan)
        cells["du"] = np.full(n, np.nan)
        if not turn.any():
            return cells, interpolants
        k = np.nonzero(turn)[0]
        u, du = P.u_of_sigma(pid[k], np.full(k.size, 0.5))
        lo, hi = P.bounds(pid[k], u)
        cells["width"][k], cells["du"][k] = hi - lo, du
        for a, b in (("s0", "t0"), ("s1", "t1")):
            cells[a], cells[b] = cells[a].copy(), cells[b].copy()
            cells[a][k], cells[b][k] = cells[b][k], cells[a][k].copy()
        interpolants = dict(interpolants)
        C = interpolants["C"].copy()
        C[k] = np.swapaxes(C[k], 2, 3)
        interpolants["C"] = C
        return cells, interpolants

    def _turned(self, cell, values, key):
        """values (m,) (line widths hi - lo, or du/dsigma) of lines in the cells cell (m,)
        (indices into _pc_cells), with the constants of turned cells (_turn_cells) put in."""
        const = self._pc_cells[key][cell]
        return np.where(np.isnan(const), values, const)

    def _lines(self, cells, budget, interpolants):
        """LINE_Q integrals (n, 7), error estimates (n, 7), fit flags (n,) and the part of
        the |K| integral's error estimate charged for unresolved sign changes of K (n,)
        (_line_values) of mixed cells with error budgets (n, 7).

        Each cell is cut in sigma at its edge crossings and, as they are found, at
        tangencies of level curves (with a clustered map at those ends, as the square-root
        behaviour there requires); the pieces are integrated by Gauss-Kronrod, and those
        whose error has a dominant sigma part and does not fit are halved, at most
        class_max_depth times. Pieces are accepted greedily against the summed budgets of
        the cells; a cell stops early once its accepted and current errors fit its budget,
        or once its accepted errors exceed it, two halves keep more than STALL_RATIO of their
        parent's error, or it holds MAX_PIECES pieces (a singular or rough integrand). A cell
        fits when its total error estimate is within its budget."""
        cells, interpolants = self._turn_cells(cells, interpolants)
        self._pc_cells, self._interp = cells, interpolants
        nc = cells["pid"].size
        out, errs, charged = np.zeros((nc, N_LINE_Q)), np.zeros((nc, N_LINE_Q)), np.zeros(nc)
        ec, es = self._edge_cuts(cells)
        ar = np.arange(nc)
        cell, sa, sb = _segments(np.concatenate((cells["s0"], es, cells["s1"])),
                                 np.concatenate((ar, ec, ar)))
        n = cell.size
        pc = dict(cell=cell, sa=sa, sb=sb, kind=np.zeros(n, int), perr=np.full(n, np.inf),
                  sib=np.full(n, -1))
        left = budget - interpolants["err"]
        for level in range(self.class_max_depth + 1):
            last = level == self.class_max_depth
            # the end lines' counts serve the tangency search only, which the last level skips
            F, e_s, e_t, e_c, sig, count, pair, ends, series = self._piece_values(pc, counted=not last)
            if last:
                tp, ts = np.empty(0, int), None
            else:  # tangencies, and corners where a level of H meets a level of K
                tp, ts = self._tangent_cuts(pc, sig, count, pair, series)
                cp, cs = self._corner_cuts(pc, sig, count, ends, series)
                tp, ts = np.concatenate((tp, cp)), np.concatenate((ts, cs))
                if level == 0:  # and islands of a class that no line of a cell meets
                    ip, is_ = self._island_cuts(pc, F)
                    tp, ts = np.concatenate((tp, ip)), np.concatenate((ts, is_))
            cut = np.zeros(pc["sa"].size, bool)
            cut[tp] = True
            c = pc["cell"]
            err = e_s + e_t
            with np.errstate(divide="ignore", invalid="ignore"):
                enorm = np.nan_to_num(err / budget[c], nan=0.0).max(1)
            # halves whose errors together did not fall below STALL_RATIO of their parent's
            sib = pc["sib"]
            halves = sib >= 0
            pair_sum = np.bincount(sib[halves], weights=enorm[halves], minlength=cut.size)
            stalled = np.zeros(nc, bool)
            stalled[c[halves & (pair_sum[np.maximum(sib, 0)] > STALL_RATIO * pc["perr"])]] = True
            total = budget - left
            total += _row_sums(c, err, nc)
            fits = np.all(total <= budget, 1) & (np.bincount(c[cut], minlength=nc) == 0)
            give_up = stalled | np.any(left < 0.0, 1) | (np.bincount(c, minlength=nc) >= MAX_PIECES)
            done = np.ones(cut.size, bool) if last else ~cut & (
                fits[c] | give_up[c] | _greedy_accept(err, left.sum(0)) | np.all(e_s <= e_t, 1))
            out += _row_sums(c[done], F[done], nc)
            errs += _row_sums(c[done], err[done], nc)
            charged += np.bincount(c[done], weights=e_c[done], minlength=nc)
            left -= _row_sums(c[done], err[done], nc)
            halve = ~done & ~cut
            pc = _cat([_split_pieces(pc, tp, ts), _halve_pieces(pc, halve, enorm)])
            if pc["sa"].size == 0:
                break
        errs += interpolants["err"]
        return out, errs, np.all(errs <= budget, 1), charged

    # -- result -------------------------------------------------------------------------------

    def snapshot(self, max_depth, seconds_start):
        """Result of the current state: accepted units plus those left pending."""
        parts = list(self.accepted)
        if self.pending is not None and self.pending["pid"].size:
            parts.append(self.pending)
        units = _cat(parts)
        Q = units["Q"].sum(0)
        err = units["err"].sum(0)
        tol = self._tolerance(Q)
        pend = self.pending if self.pending is not None else {k: v[:0] for k, v in units.items()}
        unconv = self.patches.boxes(pend["pid"], pend["s0"], pend["s1"], pend["t0"], pend["t1"])
        top = np.argsort(-units["peak"][:, 2])[:N_PEAKS]
        deep = np.nonzero(units["depth"] == units["depth"].max())[0][:N_DEEPEST]
        deepest = self.patches.boxes(*(units[k][deep] for k in ("pid", "s0", "s1", "t0", "t1")))
        nonreg = np.concatenate(self.nonregular) if self.nonregular else np.empty((0, 2))
        return QuadratureResult(
            values={q: float(x) for q, x in zip(QUANTITIES, Q)},
            errors={q: float(x) for q, x in zip(QUANTITIES, err)},
            tolerances={q: float(x) for q, x in zip(QUANTITIES, tol)},
            converged={q: bool(c) for q, c in zip(QUANTITIES, err <= tol)},
            order=self.order, rtol=self.rtol, max_depth=max_depth,
            depth_reached=int(units["depth"].max()), n_points=self.f.n_points,
            n_field_calls=self.f.n_calls, n_cells=4 * int(units["pid"].size),
            n_initial_cells=self.n_initial, n_mixed_cells=int(units["mixed"].sum()),
            nonregular_uv=nonreg, n_nonregular=self.n_nonregular, unconverged_cells=unconv,
            peak_KJ=units["peak"][top], seconds=time.perf_counter() - seconds_start,
            history=list(self.history), zero_resolved=self.resolve_zero,
            zero_charge=self.zero_charge, point_budget=self.point_budget, budget_spent=self.budget_spent,
            deepest_cells=deepest)


def patch_rule(domain, field, order, u_breaks=(), v_breaks=()):
    """Integrals of QUANTITIES by the fixed tensor Gauss-Legendre rule of the given order
    (>= 3) on every boundary-fitted patch of the domain, without refinement (an independent
    check of the adaptive cubature; class quantities with unit thresholds), and the summed
    embedded-rule differences (gauss_rules.embedded_weights) as a bound on their error: two dicts
    quantity -> float."""
    if not isinstance(domain, TrimmedDomain):
        raise InputError("patch_rule() needs a TrimmedDomain, got %s" % type(domain).__name__)
    if int(order) < 3:
        raise InputError("patch_rule() needs order >= 3, got %r" % (order,))
    it = _Integrator(domain, field, 1.0, 1.0, int(order), 1.0, 0, u_breaks, v_breaks, None)
    values = {q: float(x) for q, x in zip(QUANTITIES, it.active["Q"].sum(0))}
    bounds = {q: float(x) for q, x in zip(QUANTITIES, it.active["err_e"].sum(0))}
    return values, bounds


def cell_nodes(patches, pid, s0, s1, t0, t1, x):
    """Tensor nodes x (o,) of [0, 1] in the (sigma, t) cells [s0, s1] x [t0, t1] (n,) of the
    patches pid (n,): U, V (n, o, o) (index [cell, sigma node, t node]), and per sigma node
    du/dsigma and the strip's bounds lo, hi (n, o) (the patch map's Jacobian is
    du (hi - lo))."""
    o = x.size
    sig = s0[:, None] + (s1 - s0)[:, None] * x[None, :]
    P2 = np.repeat(pid[:, None], o, 1)
    u, du = patches.u_of_sigma(P2, sig)
    lo, hi = patches.bounds(P2, u)
    t = t0[:, None] + (t1 - t0)[:, None] * x[None, :]
    V = lo[:, :, None] + t[:, None, :] * (hi - lo)[:, :, None]
    return np.broadcast_to(u[:, :, None], V.shape), V, du, lo, hi


def tensor_cells(patches, pid):
    """(n,) bool: cells of the patches pid whose nodes (cell_nodes) form tensor grids in (u, v),
    U[c, i, :] = u_ci and V[c, :, j] = v_cj: those of patches between constant bounds
    (interior knot spans, box edges)."""
    return (patches.lo_piece[pid] < 0) & (patches.hi_piece[pid] < 0)


def values_at_nodes(pointwise, grid, tensor, U, V):
    """Arrays (n, o, o) of a field at cell nodes U, V (n, o, o): grid(U[i, :, 0], V[i, 0, :])
    on the tensor cells i (tensor_cells; grid None: none), pointwise(U[i], V[i]) on the
    others; both return a tuple of flat arrays in [c, i, j] order."""
    tensor = tensor if grid is not None else np.zeros(U.shape[0], bool)
    out = None
    for sel, values in ((tensor, lambda i: grid(U[i, :, 0], V[i, 0, :])),
                        (~tensor, lambda i: pointwise(U[i], V[i]))):
        i = np.nonzero(sel)[0]
        if i.size == U.shape[0]:
            return tuple(a.reshape(U.shape) for a in values(i))
        if i.size:
            vals = values(i)
            out = out or [np.empty(U.shape, a.dtype) for a in vals]
            for a, b in zip(out, vals):
                a[i] = b.reshape(i.size, *U.shape[1:])
    return tuple(out)


def patch_area(domain, area_element, order, u_breaks=(), v_breaks=(), area_element_grid=None):
    """Represented area by the fixed tensor Gauss-Legendre rule of the given order (>= 3) on
    every boundary-fitted patch of the domain (the nodes and weights of patch_rule), from
    area_element(u, v) -> dict with J alone (and area_element_grid(u, v), the same on tensor
    grids as FaceField.area_element_grid, for the patches between constant bounds), and the
    summed embedded-rule differences as a bound on its error: (area, bound)."""
    if not isinstance(domain, TrimmedDomain):
        raise InputError("patch_area() needs a TrimmedDomain, got %s" % type(domain).__name__)
    order = int(order)
    if order < 3:
        raise InputError("patch_area() needs order >= 3, got %r" % (order,))
    x, w = gauss_nodes(order)
    we = embedded_weights(x)
    patches = Patches.of(domain, u_breaks, v_breaks)
    n = patches.size
    zero, one = np.zeros(n), np.ones(n)
    pid = np.arange(n)
    U, V, du, lo, hi = cell_nodes(patches, pid, zero, one, zero, one, x)
    grid = None if area_element_grid is None else (
        lambda u, v: (np.asarray(area_element_grid(u, v)["J"], dtype=float).ravel(),))
    J, = values_at_nodes(lambda u, v: (np.asarray(area_element(u.ravel(), v.ravel())["J"], dtype=float).ravel(),),
                         grid, tensor_cells(patches, pid), U, V)
    J = np.where(np.isfinite(J), J, 0.0)  # as the cubature's fields: no area where J is undefined
    G = (du * (hi - lo))[:, :, None] * J  # the patch map's Jacobian times J at the nodes
    area = np.einsum("cij,i,j->c", G, w, w)
    bound = np.abs(area - np.einsum("cij,i,j->c", G, we, we))
    return float(area.sum()), float(bound.sum())


def patch_groups(n_patches, min_patches=None):
    """Patch index ranges [(start, stop), ...] in which a face of n_patches boundary-fitted
    patches is integrated: GROUPS consecutive ranges of equal size when the face has at least
    min_patches (default GROUP_MIN_PATCHES), else the whole face. It depends on the geometry
    only, so the values do not depend on how many processes integrate the groups."""
    n = int(n_patches)
    g = GROUPS if n >= (GROUP_MIN_PATCHES if min_patches is None else min_patches) else 1
    cuts = [(k * n) // g for k in range(g + 1)]
    return [(a, b) for a, b in zip(cuts[:-1], cuts[1:])]


def integrate(domain, field, tau_H, tau_K, order=5, rtol=1e-4, max_depth=5, u_breaks=(),
              v_breaks=(), progress=None, recheck=True, class_max_depth=2, reference=None,
              lines=True, patch_range=None, prefetch=None, depth_limit=None, point_budget=None):
    """Adaptive boundary-fitted cubature of the signature integrals over a trimmed domain.

    domain: TrimmedDomain. field(u, v), u and v (n,) float, returns a dict (or an object
    with attributes) of (n,) arrays J = |S_u x S_v| (eq:brep_jacobian), K, H (eq:brephk)
    and bool regular. tau_H, tau_K > 0: class thresholds (eq:class_thresholds). order:
    Gauss-Legendre points per direction; rtol: relative tolerance per quantity; max_depth:
    quadtree levels below the initial patches; u_breaks, v_breaks: knot lines where the
    integrand is less smooth (cells are cut there); progress(fraction, message) or None;
    recheck: when something did not converge, continue one level deeper and attach that
    result as ``recheck`` (paper section 5.2); class_max_depth: halvings in sigma of a
    mixed cell's line integrals; reference: dict quantity -> magnitude that the tolerance
    is relative to at least (for a piece of a larger integral, e.g. a singular neighbourhood
    integrated apart from its face: its share of the face's tolerance); lines: integrate
    mixed cells on lines (False: Gauss sums throughout, the quadtree's own error estimates;
    class areas then converge only like the cell size, for callers that need the area and
    K integrals only); patch_range: (start, stop) of the domain's patches to integrate
    (default all; see patch_groups), with tolerances relative to their own integrals;
    prefetch: a NodePrefetch of the same domain, field, order, breaks and patch range, whose
    values are used where it has them. depth_limit: refinement driven by the error alone:
    the cells left unaccepted are refined down to depth_limit levels below the patches
    (max_depth then only bounds the halving of few patches into first cells, and there is
    no recheck), while the field points stay within point_budget (None: no limit); the
    result says whether the budget stopped it (budget_spent).
    Returns a QuadratureResult.
    """
    if not isinstance(domain, TrimmedDomain):
        raise InputError("integrate() needs a TrimmedDomain, got %s" % type(domain).__name__)
    tau_H = check_positive("tau_H", tau_H)
    tau_K = check_positive("tau_K", tau_K)
    check_positive("rtol", rtol)
    if int(order) < 1 or int(max_depth) < 1 or int(class_max_depth) < 0:
        raise InputError("quadrature order and max_depth must be >= 1 and class_max_depth "
                         ">= 0, got %r, %r, %r" % (order, max_depth, class_max_depth))
    start = time.perf_counter()
    it = _Integrator(domain, field, tau_H, tau_K, int(order), float(rtol), int(class_max_depth),
                     u_breaks, v_breaks, progress, patch_range, prefetch, int(max_depth))
    it.reference = np.array([abs(float((reference or {}).get(q, 0.0))) for q in QUANTITIES])
    it.lines = bool(lines)
    if depth_limit is not None:
        it.point_budget = None if point_budget is None else int(point_budget)
        it.refine_to(int(depth_limit), it.point_budget)
        result = it.snapshot(int(depth_limit), start)
        if progress is not None:
            progress(1.0, "quadrature done: %d points" % it.f.n_points)
        return result
    it.refine_to(int(max_depth))
    result = it.snapshot(int(max_depth), start)
    if recheck and not result.all_converged:
        it.refine_to(int(max_depth) + 1)
        result.recheck = it.snapshot(int(max_depth) + 1, start)
    if progress is not None:
        progress(1.0, "quadrature done: %d points" % it.f.n_points)
    return result
