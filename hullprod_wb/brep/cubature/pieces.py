"""Pieces of the lines of mixed cells, shared by the line integration and the cut search:
what both read of the integration (LineSetting), the mixed cells with their interpolants, segments of a line between cuts, crossing counts and pairs of a level, pieces split at or
halved between parameters, and a parabolic search for the extremum of a level function
between samples."""
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from .cells import CellSet
from .settings import EDGE_XI, LEVEL_ROW, N_LEVELS, PARABOLIC_STEPS


@dataclass(frozen=True, eq=False)
class LineSetting:
    """What the line integration and the cut search read of one integration: its patches,
    the field (counting its points, cells.CountedField), the class thresholds tau_H, tau_K
    (eq:class_thresholds), the halvings in sigma of a cell's lines (class_max_depth), the
    interpolants' grid matrices (cell_interpolant.grid_matrices_of_order) and whether K = 0 cuts the
    lines (resolve_zero; a new setting is made when it is switched on)."""

    patches: object
    field: object
    tau_H: float
    tau_K: float
    class_max_depth: int
    grid_inverse: np.ndarray
    parent_vander: np.ndarray
    resolve_zero: bool = False
    #: constants the level functions subtract from their field row (LEVEL_ROW)
    level_offset: np.ndarray = field(init=False)

    def __post_init__(self):
        object.__setattr__(self, "level_offset", np.array([self.tau_K, -self.tau_K, self.tau_H, -self.tau_H, 0.0]))

    def thresholds(self, K, H):
        """(n, 5) level functions K - tau_K, K + tau_K, H - tau_H, H + tau_H, K: the field of
        LEVEL_ROW minus level_offset."""
        rows = (None, K, H)
        return np.stack([rows[r] for r in LEVEL_ROW], -1) - self.level_offset


class LinePieces(NamedTuple):
    """The pieces between crossings of lines (lines.line_values), all (k,) but J, KJ."""

    #: the line of each piece, its ends in t, the line's t0 and span t1 - t0
    line: np.ndarray
    a: np.ndarray
    b: np.ndarray
    t0: np.ndarray
    span: np.ndarray
    #: bool: on an interpolant's line; short pieces on the field
    poly: np.ndarray
    short: np.ndarray
    #: the long pieces, then the whole lines (indices): integrated by Gauss-Kronrod
    kronrod: np.ndarray
    n_kronrod: int
    #: J and K J at the Kronrod nodes of the kronrod pieces (7 each), then at the midpoints
    J: np.ndarray
    KJ: np.ndarray
    #: K and the class at each piece's midpoint
    K_mid: np.ndarray
    cls: np.ndarray


class LineCrossings(NamedTuple):
    """Crossings of the level functions on lines (count_and_pairs)."""

    #: (L, 5) crossings of each level on each line
    count: np.ndarray
    #: (L, 5, 2) the closest two crossings of each level (NaN when fewer than two)
    pair: np.ndarray
    #: (L, 5, 2) the first and last crossing of each level (NaN when none)
    ends: np.ndarray

    def take(self, index):
        """The crossings of the lines index (a slice, mask or indices)."""
        return LineCrossings(self.count[index], self.pair[index], self.ends[index])


class LineSamples:
    """The field at the samples ZS of n lines (crossings.crossings): J, K J (both 0
    where not regular), K, H and reg (n, 9); zero (n,) bool: K changes sign on the line by
    the samples (set by the crossing search)."""

    __slots__ = ("J", "KJ", "K", "H", "reg", "zero")

    def __init__(self, J, KJ, K, H, reg):
        self.J, self.KJ, self.K, self.H, self.reg = J, KJ, K, H, reg
        self.zero = None


class LineValues(NamedTuple):
    """The integrals of L lines (lines.line_values)."""

    #: (L, 7) integrals of the LINE_Q integrands times (hi - lo) dt
    F: np.ndarray
    #: (L, 7) their error estimates
    E: np.ndarray
    #: (L,) the bound charged to E's |K| column for sign changes of K left unresolved
    C: np.ndarray
    #: the lines' power series on interpolants (SegmentField.power)
    power: np.ndarray
    #: the crossings of each level on each line
    crossings: LineCrossings


@dataclass(frozen=True)
class Interpolants:
    """Tensor interpolants of J, K, H over mixed cells (cell_interpolant), all (m, ...) arrays."""

    #: Legendre coefficients (m, 3, 2o, 2o) of J, K, H in the cell's local (sigma, t)
    C: np.ndarray
    #: (m,) bool: the cell's lines run on its interpolant (else on the field)
    use: np.ndarray
    #: (m, 7) the interpolant's error in each LINE_Q integral (0 where not used)
    err: np.ndarray

    def take(self, keep):
        """The interpolants of the cells keep (a mask or indices)."""
        return Interpolants(self.C[keep], self.use[keep], self.err[keep])


@dataclass(frozen=True)
class MixedCells:
    """The mixed cells whose lines are integrated, lines along t (turned cells: sigma and t
    exchanged, see lines.turn_cells), with their interpolants."""

    #: the cells' patches and boxes in (sigma, t) (their boxes alone)
    boxes: CellSet
    #: (n,) the constant strip width hi - lo of turned cells (NaN: not turned)
    width: np.ndarray
    #: (n,) the constant du/dsigma of turned cells (NaN: not turned)
    du: np.ndarray
    #: the cells' interpolants (turned with their cells)
    interp: Interpolants

    @property
    def size(self):
        return self.width.size

    def turned(self, cell, values, key):
        """values (m,) (line widths hi - lo for key "width", du/dsigma for "du") of lines in
        the cells cell (m,), with the constants of turned cells put in."""
        const = getattr(self, key)[cell]
        return np.where(np.isnan(const), values, const)


@dataclass(frozen=True)
class Pieces:
    """Pieces [sa, sb] in sigma of the lines of mixed cells, all (n,) arrays."""

    #: the mixed cell of each piece (index into the cells being integrated on lines)
    cell: np.ndarray
    #: the piece's ends in sigma
    sa: np.ndarray
    sb: np.ndarray
    #: clustered ends (cluster_map): 1 the lower, 2 the upper, 3 both, 0 none
    kind: np.ndarray
    #: the error (relative to the budget) of the piece this one is a half of (inf: none)
    perr: np.ndarray
    #: the index of that parent piece, shared by both halves (-1: not a half)
    sib: np.ndarray

    @property
    def size(self):
        return self.sa.size

    @classmethod
    def whole(cls, cell, sa, sb):
        """Pieces of no clustered end and no parent."""
        n = cell.size
        return cls(cell, sa, sb, np.zeros(n, int), np.full(n, np.inf), np.full(n, -1))

    def empty(self):
        """No pieces (the arrays' types kept)."""
        return Pieces(self.cell[:0], self.sa[:0], self.sb[:0], self.kind[:0], self.perr[:0], self.sib[:0])

    @staticmethod
    def concatenate(parts):
        """The pieces of parts, one after the other."""
        return Pieces(*(np.concatenate([getattr(p, k) for p in parts])
                        for k in ("cell", "sa", "sb", "kind", "perr", "sib")))


def cut_segments(cuts, owner):
    """Consecutive pairs of sorted cut values per owner: (owner, a, b) of non-empty pieces.

    cuts, owner (k,); every owner must have its two end values among the cuts."""
    o = np.lexsort((cuts, owner))
    c, w = cuts[o], owner[o]
    k = np.nonzero((w[:-1] == w[1:]) & (c[1:] > c[:-1]))[0]
    return w[k], c[k], c[k + 1]


def count_and_pairs(line, level, roots, L):
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
    return LineCrossings(count, pair, ends)


def parabolic_min(fun, x, f, steps=PARABOLIC_STEPS):
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


def split_pieces(pc, piece, at):
    """Pieces pc cut at sigma values at (k,) of pieces piece (k,); the new ends are
    clustered (cluster_map), old ends keep their clustering."""
    if piece.size == 0:
        return pc.empty()
    ids = np.unique(piece)
    cuts = np.concatenate((pc.sa[ids], at, pc.sb[ids]))
    owner = np.concatenate((ids, piece, ids))
    w, a, b = cut_segments(cuts, owner)
    keep_lo = (a == pc.sa[w]) & (pc.kind[w] & 1 > 0)
    keep_hi = (b == pc.sb[w]) & (pc.kind[w] & 2 > 0)
    lo_tan = (a != pc.sa[w]) | keep_lo
    hi_tan = (b != pc.sb[w]) | keep_hi
    return Pieces(pc.cell[w], a, b, lo_tan.astype(int) + 2 * hi_tan.astype(int),
                  np.full(w.size, np.inf), np.full(w.size, -1))


def halve_pieces(pc, mask, err):
    """The two halves (in sigma) of the pieces pc[mask]; each keeps its outer clustering,
    and records its parent's error err[mask] (n,) and a sibling id (its parent's index)."""
    cell, sa, sb, kind = pc.cell[mask], pc.sa[mask], pc.sb[mask], pc.kind[mask]
    mid = 0.5 * (sa + sb)
    return Pieces(np.repeat(cell, 2), np.stack((sa, mid), 1).ravel(), np.stack((mid, sb), 1).ravel(),
                  np.stack((kind & 1, kind & 2), 1).ravel(), np.repeat(err[mask], 2),
                  np.repeat(np.nonzero(mask)[0], 2))


def inside_pieces(pc, piece, at):
    """Whether the sigma values at (k,) lie inside the pieces piece (k,) of pc, farther than
    EDGE_XI of their width from both ends (a cut there would leave a needless sliver)."""
    w = pc.sb[piece] - pc.sa[piece]
    return (at > pc.sa[piece] + EDGE_XI * w) & (at < pc.sb[piece] - EDGE_XI * w)
