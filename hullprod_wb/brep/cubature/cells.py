"""Cells of the quadtree over the boundary-fitted patches: the first cells (the patches,
halved in both directions up to MIN_INITIAL_CELLS of them), their children, the tensor
Gauss nodes of a cell mapped to (u, v), the field at them (on tensor grids where the cell
lies between constant bounds), the cells that may meet a class boundary, the prefetch of
the first two levels, and the greedy acceptance of cells against an error budget."""
import numpy as np

from ...core.errors import InputError
from .gauss_rules import gauss_rule
from .patches import Patches
from .settings import ACCEPT_FRACTION, AREA, CLASS_AREAS, MIN_INITIAL_CELLS, PREFETCH_CELLS, STRADDLE_MARGIN


#: The arrays of a CellSet: the cells' boxes, then those known once evaluated or accepted.
_BOXES = ("pid", "s0", "s1", "t0", "t1")
_ARRAYS = _BOXES + ("Q", "err_e", "mixed", "peak", "pmeas", "sJ", "sK", "sH", "sreg", "row", "depth", "err")


def grid_points(u, v):
    """The points of the tensor grids u (n, a) x v (n, b), (u[c, i], v[c, j]), as two flat
    arrays (n a b,) in [c, i, j] order."""
    u, v = np.asarray(u, dtype=float), np.asarray(v, dtype=float)
    shape = (u.shape[0], u.shape[1], v.shape[1])
    return np.broadcast_to(u[:, :, None], shape).ravel(), np.broadcast_to(v[:, None, :], shape).ravel()


class CellSet:
    """Cells of the quadtree, one row a cell in every array (None: not known yet), sliced and
    joined as whole arrays (take, concat):

    - pid (n,) int: each cell's patch; s0, s1, t0, t1 (n,): its box [s0, s1] x [t0, t1] in
      the patch's (sigma, t) (always given);
    - from the evaluation (Integration.evaluate): Q (n, 9) integrals of QUANTITIES (Gauss
      sums; a unit's: its children's sums or lines), err_e (n, 9) |Q - Q_embedded|
      (gauss_rules.embedded_weights), mixed (n,) bool: the cell may meet a class boundary or
      K = 0 (a unit: one of its children), peak (n, 3) u, v, |K| J at the sample of largest
      |K| J, pmeas (n,) parameter area, and the samples sJ, sK, sH, sreg (n, o, o) of J, K, H,
      regular (index [cell, sigma node, t node]);
    - row (n,) int: the first cell (of a prefetch) of each cell;
    - of accepted or pending units: depth (n,) int, the level of their children (or of the
      cell accepted on its own), and err (n, 9) their error estimates."""

    __slots__ = _ARRAYS

    def __init__(self, pid, s0, s1, t0, t1, **arrays):
        self.pid, self.s0, self.s1, self.t0, self.t1 = pid, s0, s1, t0, t1
        for name in _ARRAYS[5:]:
            setattr(self, name, arrays.pop(name, None))
        if arrays:
            raise TypeError("CellSet has no arrays %s" % ", ".join(sorted(arrays)))

    @property
    def size(self):
        return self.pid.size

    def boxes(self):
        """The cells' boxes alone (the same arrays)."""
        return CellSet(self.pid, self.s0, self.s1, self.t0, self.t1)

    def take(self, index):
        """The cells index (a mask, indices or a slice) of every array present."""
        return CellSet._of([None if a is None else a[index] for a in self._arrays()])

    def with_(self, **arrays):
        """These cells with the arrays given set (the others kept)."""
        out = CellSet._of([arrays.pop(name, a) for name, a in zip(_ARRAYS, self._arrays())])
        if arrays:
            raise TypeError("CellSet has no arrays %s" % ", ".join(sorted(arrays)))
        return out

    @staticmethod
    def concat(parts):
        """The cells of parts (CellSets of the same arrays present), one after the other."""
        columns = zip(*(p._arrays() for p in parts))
        return CellSet._of([None if c[0] is None else np.concatenate(c) for c in columns])

    def _arrays(self):
        return [getattr(self, name) for name in _ARRAYS]

    @staticmethod
    def _of(arrays):
        """The CellSet of all its arrays, in _ARRAYS order."""
        out = object.__new__(CellSet)
        for name, a in zip(_ARRAYS, arrays):
            setattr(out, name, a)
        return out


class CountedField:
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


def greedy_accept(err, budget, group=None):
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


def row_sums(rows, values, n):
    """Sums (n, q) of the rows (k, q) of values that belong to each index of rows (k,)."""
    out = np.empty((n, values.shape[1]))
    for j in range(values.shape[1]):
        out[:, j] = np.bincount(rows, weights=values[:, j], minlength=n)
    return out


def share_area_error(err, Q):
    """err (n, 9) with the class areas' columns set to the area's error shared by each
    cell's class fractions (from its integrals Q (n, 9)): outside mixed cells a class area
    is the area of the cell's one class. A fraction is at most 1 (a cell of no area in
    rounding, or a negative one, would otherwise divide by it)."""
    frac = Q[:, CLASS_AREAS] / np.maximum(Q[:, AREA, None], 1e-300)
    err[:, CLASS_AREAS] = err[:, AREA, None] * np.minimum(np.abs(frac), 1.0)
    return err


def patch_cells(patches, patch_range=None, max_depth=None):
    """The quadtree's first cells (a CellSet of boxes) and their level: the
    whole of each patch of patch_range (start, stop) (default all), at level 0, halved in
    both directions (child_cells) until there are MIN_INITIAL_CELLS of them, at most to level
    max_depth - 1 (None: no halving); InputError when the range holds no patch."""
    pid = np.arange(patches.size)
    if patch_range is not None:
        pid = pid[slice(*patch_range)]
        if pid.size == 0:
            raise InputError("patch range %r holds none of the domain's %d patches"
                             % (tuple(patch_range), patches.size))
    z, o = np.zeros(pid.size), np.ones(pid.size)
    cells, level = CellSet(pid, z, o, z, o), 0
    while max_depth is not None and cells.size < MIN_INITIAL_CELLS and level < max_depth - 1:
        cells, level = child_cells(cells), level + 1
    return cells, level


def child_cells(a):
    """The four children (a CellSet of (4n,) boxes) of the cells a (CellSet), each cell's
    children consecutive: (low, low), (high, low), (low, high), (high, high) in (sigma, t)."""
    sm = 0.5 * (a.s0 + a.s1)
    tm = 0.5 * (a.t0 + a.t1)
    return CellSet(np.repeat(a.pid, 4),
                   np.stack((a.s0, sm, a.s0, sm), 1).ravel(),
                   np.stack((sm, a.s1, sm, a.s1), 1).ravel(),
                   np.stack((a.t0, a.t0, tm, tm), 1).ravel(),
                   np.stack((tm, tm, a.t1, a.t1), 1).ravel())


def mixed_cells(cls, K, H, reg, tau_H, tau_K):
    """(n,) bool: cells (n, o, o samples of class cls, K, H, regular) that may meet a class
    boundary (thresholds tau_H, tau_K) or K = 0: their samples' classes differ, or the sampled
    range of K (of H where |K| may be below tau_K), widened by STRADDLE_MARGIN of itself,
    contains a threshold, or K changes sign in it."""
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
    tk, th = tau_K, tau_H
    # K = 0 only matters where K changes sign (a kink of |K|); K identically zero (planes,
    # cylinders, cones) has none
    out |= meets(klo, khi, -tk, tk) | ((klo < 0.0) & (khi > 0.0)) \
        | (klo <= tk) & (khi >= -tk) & meets(hlo, hhi, -th, th)
    return anyreg & out


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
        self.f = CountedField(field)
        self.order = int(order)
        self.x = gauss_rule(self.order)[0]
        self.patches = patches if patches is not None else Patches.of(domain, u_breaks, v_breaks)
        self.cells = [patch_cells(self.patches, patch_range, int(max_depth))[0]]
        self.cells.append(child_cells(self.cells[0]))
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
            k = slice(a, min(a + PREFETCH_CELLS, c.size))
            nodes = cell_nodes(self.patches, c.pid[k], c.s0[k], c.s1[k], c.t0[k], c.t1[k], self.x)
            before = self.f.n_calls
            values = values_at_nodes(self.f, self.f.grid, tensor_cells(self.patches, c.pid[k]), *nodes[:2])
            self._chunks.append((values, nodes, self.f.n_calls - before))
            if k.stop == c.size:  # the level is complete
                for out, part in ((self.values, 0), (self.nodes, 1)):
                    out.append(tuple(np.concatenate(v) for v in zip(*(ch[part] for ch in self._chunks))))
                self.calls.append(sum(ch[2] for ch in self._chunks))
                self._chunks = []
        return len(self.values) < len(self.cells)


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
