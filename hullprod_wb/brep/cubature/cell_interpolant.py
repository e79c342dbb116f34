"""Local tensor interpolants of J, K, H over mixed quadtree cells.

The four children of a parent cell carry o x o Gauss-Legendre samples each; together they
form a 2o x 2o tensor grid of the parent. The interpolant of a field f on the parent is the
tensor Legendre series of degree 2o - 1 through that grid,
    f(xi, eta) ~ sum_{a,b} C_ab P_a(2 xi - 1) P_b(2 eta - 1),   C = V^-1 F V^-T,
in the parent's local coordinates (xi, eta) in [0, 1]^2 (V: the Legendre-Vandermonde matrix
of the grid nodes; its condition number is 122 for o = 5). Its error is measured where it
was not fitted, at the parent's own o x o Gauss nodes. The adaptive cubature
(hullprod_wb.brep.cubature) integrates a mixed cell on lines of its interpolant when that
error is small enough, instead of evaluating the surface along the lines.

On a line of the cell (a segment, SegmentField) the interpolant is a Legendre series of one
variable; it is also kept in powers of the segment's local coordinate z in [-1, 1], on which
level crossings are refined by safeguarded Newton steps, J and K J are integrated exactly
(antiderivatives of the series and of their product) and least values over windows are found
(the tangency search of the cubature).
"""
import functools
from typing import NamedTuple

import numpy as np

from .gauss_rules import gauss_rule, legendre_vander, read_only

#: Points per block of two-dimensional interpolant evaluations (bounds the memory of the
#: gathered coefficients: block x 3 x (2o)^2 floats).
CHUNK = 20000


def grid_matrices(x):
    """For Gauss nodes x (o,) on [0, 1]: the inverse (2o, 2o) of the Legendre-Vandermonde
    matrix of the children's grid (x / 2, 1/2 + x / 2) and the Vandermonde rows (o, 2o) of the
    parent's own nodes x."""
    o = x.size
    grid = np.concatenate((0.5 * x, 0.5 + 0.5 * x))
    LV = legendre_vander
    return np.linalg.inv(LV(2.0 * grid - 1.0, 2 * o - 1)), LV(2.0 * x - 1.0, 2 * o - 1)


@functools.lru_cache(maxsize=None)
def grid_matrices_of_order(order):
    """grid_matrices of the Gauss nodes of order (gauss_rules.gauss_rule), made once an
    order, read-only."""
    return tuple(read_only(a) for a in grid_matrices(gauss_rule(order)[0]))


class InterpolantFit(NamedTuple):
    """Interpolants of J, K, H over m cells (fit_interpolants)."""

    #: (m, 3, 2o, 2o) Legendre coefficients of J, K, H
    C: np.ndarray
    #: (m, 3) max |interpolant - f| at the parent's nodes for f = J, K, H
    d: np.ndarray
    #: (m,) the same for K J
    dKJ: np.ndarray
    #: (m, 3) the range of the samples of J, K, H
    lo: np.ndarray
    hi: np.ndarray
    #: (m,) all samples regular and finite
    reg: np.ndarray


def fit_interpolants(parent, children, idx, grid_inverse, parent_vander):
    """Interpolants of J, K, H over the cells parent[idx] from their children's samples.

    parent, children: cells (cubature.cells.CellSet) with samples sJ, sK, sH (n, o, o) and
    sreg (n, o, o) bool, the
    children of parent i at rows 4 i .. 4 i + 3 (sigma low/t low, sigma high/t low, sigma
    low/t high, sigma high/t high). Returns an InterpolantFit."""
    o = parent_vander.shape[0]
    m = idx.size
    F = np.empty((m, 3, 2 * o, 2 * o))
    for f, samples in enumerate((children.sJ, children.sK, children.sH)):
        c = samples.reshape(-1, 4, o, o)[idx]
        F[:, f, :o, :o], F[:, f, o:, :o] = c[:, 0], c[:, 1]
        F[:, f, :o, o:], F[:, f, o:, o:] = c[:, 2], c[:, 3]
    reg = children.sreg.reshape(-1, 4 * o * o)[idx].all(1) & parent.sreg[idx].reshape(m, -1).all(1)
    reg &= np.isfinite(F).reshape(m, -1).all(1)
    C = grid_inverse @ np.where(np.isfinite(F), F, 0.0) @ grid_inverse.T
    S = parent_vander @ C @ parent_vander.T
    P = np.stack([parent.sJ[idx], parent.sK[idx], parent.sH[idx]], 1)
    with np.errstate(invalid="ignore"):
        d = np.abs(S - P).reshape(m, 3, -1).max(2)
        dKJ = np.abs(S[:, 1] * S[:, 0] - P[:, 1] * P[:, 0]).reshape(m, -1).max(1)
    reg &= np.isfinite(d).all(1) & np.isfinite(dKJ)
    vals = np.concatenate((F.reshape(m, 3, -1), P.reshape(m, 3, -1)), 2)
    return InterpolantFit(C, d, dKJ, vals.min(2), vals.max(2), reg)


def local_coordinate(x, a, b):
    return 2.0 * (x - a) / (b - a) - 1.0


@functools.lru_cache(maxsize=None)
def monomial_matrix(deg):
    """(deg + 1, deg + 1) matrix M with P_k(z) = sum_j M[k, j] z^j (Legendre polynomials
    in powers of z, from k P_k = (2k - 1) z P_(k-1) - (k - 1) P_(k-2)); read-only, one per
    degree."""
    M = np.zeros((deg + 1, deg + 1))
    M[0, 0] = 1.0
    if deg > 0:
        M[1, 1] = 1.0
    for k in range(2, deg + 1):
        M[k, 1:] = (2 * k - 1) / k * M[k - 1, :-1]
        M[k] -= (k - 1) / k * M[k - 2]
    M.flags.writeable = False
    return M


def horner(C, z):
    """sum_j C[:, j] z^j for coefficient rows C (n, d + 1) and z (n,) or (n, m) (row i of z
    with row i of C); the shape of z."""
    z = np.asarray(z, dtype=float)
    ext = (slice(None),) + (None,) * (z.ndim - 1)
    acc = np.zeros(z.shape) + C[:, -1][ext]
    for j in range(C.shape[1] - 2, -1, -1):
        acc *= z
        acc += C[:, j][ext]
    return acc


def horner2(C, z):
    """Values, first and second derivatives (three (n,) arrays) at z (n,) of the power
    series with coefficient rows C (n, d + 1), in one Horner pass."""
    p = C[:, -1].copy()
    d1 = np.zeros_like(p)
    d2 = np.zeros_like(p)
    for j in range(C.shape[1] - 2, -1, -1):
        d2 = d2 * z + 2.0 * d1
        d1 = d1 * z + p
        p = p * z + C[:, j]
    return p, d1, d2


def horner_columns(C, z):
    """sum_j C[j] z^j for coefficient columns C (d + 1, n) and z (n,): Horner's scheme on
    contiguous rows (the same arithmetic as horner on the transposed coefficients)."""
    acc = C[-1].copy()
    for j in range(C.shape[0] - 2, -1, -1):
        acc *= z
        acc += C[j]
    return acc


def product_columns(A, B):
    """Coefficient columns (2 d + 1, n) of the products of the power series with coefficient
    columns A and B (d + 1, n): c_k = sum_(i + j = k) a_i b_j, one shifted multiply-add per
    coefficient of A."""
    d1 = A.shape[0]
    out = np.zeros((2 * d1 - 1, A.shape[1]))
    for i in range(d1):
        out[i:i + d1] += A[i] * B
    return out


def antiderivative_columns(C):
    """Coefficient columns (d + 2, n) of the antiderivatives, zero at z = 0, of the power
    series with coefficient columns C (d + 1, n)."""
    out = np.zeros((C.shape[0] + 1, C.shape[1]))
    out[1:] = C / np.arange(1, C.shape[0] + 1)[:, None]
    return out


#: Most safeguarded Newton steps for a crossing on a segment's series (one Horner pair a
#: step for the brackets still open; a simple root needs about five).
NEWTON_STEPS = 60
#: Samples of a window, and Newton steps on the derivative after them, for the least value
#: of a segment's series over the window (SegmentField.window_min).
WINDOW_SAMPLES = 17
WINDOW_STEPS = 4


def cell_values(C, cells, cell, sig, t):
    """J, K, H (m,) of the interpolants C (n, 3, 2o, 2o) of cells (with (n,) s0, s1, t0,
    t1: a cubature.cells.CellSet) at patch coordinates (sig, t) (m,) of the cells cell (m,)."""
    deg = C.shape[-1] - 1
    PX = legendre_vander(local_coordinate(sig, cells.s0[cell], cells.s1[cell]), deg)
    PE = legendre_vander(local_coordinate(t, cells.t0[cell], cells.t1[cell]), deg)
    out = np.empty((cell.size, 3))
    for a in range(0, cell.size, CHUNK):
        b = slice(a, a + CHUNK)
        row = np.matmul(PX[b, None, None, :], C[cell[b]])[:, :, 0, :]
        out[b] = (row * PE[b, None, :]).sum(2)
    return out.T


def _restricted_series(C, cell, P, along_t):
    """Legendre series (m, 3, d + 1) of the tensor series C (n, 3, d + 1, d + 1) restricted to
    lines of the cells cell (m,) whose fixed coordinate has the Legendre values P (m, d + 1):
    sum_a P_a C[:, a, b] for lines along t (sigma fixed), sum_b P_b C[:, a, b] along sigma.
    Consecutive lines of one cell (the lines of a piece) share one gathered copy of its
    coefficients: runs of equal length are done by one batched product each."""
    m, d1 = P.shape
    start = np.nonzero(np.r_[True, cell[1:] != cell[:-1]])[0]
    length = np.diff(np.r_[start, m])
    rows = C[cell[start]]  # (runs, 3, d + 1, d + 1)
    rows = rows.transpose(0, 2, 1, 3) if along_t else rows.transpose(0, 3, 1, 2)
    rows = rows.reshape(start.size, d1, 3 * d1)  # [run, fixed-direction degree, (field, degree)]
    out = np.empty((m, 3 * d1))
    for k in np.unique(length):
        r = np.nonzero(length == k)[0]
        lines = (start[r, None] + np.arange(k)[None, :]).ravel()
        out[lines] = np.matmul(P[lines].reshape(r.size, k, d1), rows[r]).reshape(-1, 3 * d1)
    return out.reshape(m, 3, d1)


class SegmentField:
    """J, K, H, regular along segments of mixed cells, for the cubature's line code.

    A segment is a line sigma = fixed (axis "t": its parameter x is t) or t = fixed (axis
    "sigma": x is sigma) of the cell cell (index into cells, a CellSet: (n,) s0, s1, t0, t1).
    Segments of cells with use[cell] are evaluated on the interpolant's restriction to the
    segment (a Legendre series in x, its coefficients computed once per segment); the
    others by fallback(x, seg) -> (J, K, H, regular) for parameters x of segments seg.
    """

    def __init__(self, C, use, cells, cell, fixed, axis, fallback):
        self.axis, self.fallback = axis, fallback
        self.cell, self.fixed = np.asarray(cell), np.asarray(fixed, dtype=float)
        self.use = use[self.cell]
        c = self.cell
        if axis == "t":
            a, b = cells.s0[c], cells.s1[c]
            self.x0, self.x1 = cells.t0[c], cells.t1[c]
        else:
            a, b = cells.t0[c], cells.t1[c]
            self.x0, self.x1 = cells.s0[c], cells.s1[c]
        deg = C.shape[-1] - 1
        i = np.nonzero(self.use)[0]
        self.coef = np.zeros((c.size, 3, deg + 1))
        if i.size:
            P = legendre_vander(local_coordinate(self.fixed[i], a[i], b[i]), deg)
            self.coef[i] = _restricted_series(C, c[i], P, axis == "t")
        # the same series in powers of the local coordinate z in [-1, 1] (J, K, H rows), by
        # one product for all rows (a stacked product would make one BLAS call per segment)
        self.power = (self.coef.reshape(-1, deg + 1) @ monomial_matrix(deg)).reshape(self.coef.shape)
        self._antiderivatives = None

    def __call__(self, x, seg):
        x, seg = np.asarray(x, dtype=float).ravel(), np.asarray(seg).ravel()
        n = x.size
        J, K, H = np.empty(n), np.empty(n), np.empty(n)
        reg = np.ones(n, bool)
        use = self.use[seg]
        i = np.nonzero(use)[0]
        if i.size:
            s = seg[i]
            P = legendre_vander(local_coordinate(x[i], self.x0[s], self.x1[s]), self.coef.shape[2] - 1)
            J[i], K[i], H[i] = np.einsum("mk,mfk->fm", P, self.coef[s])
        i = np.nonzero(~use)[0]
        if i.size:
            J[i], K[i], H[i], reg[i] = self.fallback(x[i], seg[i])
        return J, K, H, reg

    def samples(self, zs):
        """J, K, H, regular (n m,) of every segment k at the fractions zs (m,) of its range,
        x = x0[k] + (x1[k] - x0[k]) zs, in the order of self(x.ravel(), np.repeat(np.arange(n),
        m)). On interpolants the local coordinates 2 zs - 1 are the same for every segment:
        one Legendre-Vandermonde matrix and one product for all of them."""
        zs = np.asarray(zs, dtype=float)
        n, m = self.x0.size, zs.size
        out = np.empty((3, n, m))
        reg = np.ones((n, m), bool)
        i = np.nonzero(self.use)[0]
        if i.size:
            d1 = self.coef.shape[2]
            V = legendre_vander(2.0 * zs - 1.0, d1 - 1)  # (m, d + 1)
            out[:, i] = (self.coef[i].reshape(-1, d1) @ V.T).reshape(i.size, 3, m).transpose(1, 0, 2)
        i = np.nonzero(~self.use)[0]
        if i.size:
            xs = self.x0[i, None] + (self.x1 - self.x0)[i, None] * zs[None, :]
            f = self.fallback(xs.ravel(), np.repeat(i, m))
            for row in range(3):
                out[row, i] = f[row].reshape(-1, m)
            reg[i] = f[3].reshape(-1, m)
        return out[0].ravel(), out[1].ravel(), out[2].ravel(), reg.ravel()

    def local(self, x, seg):
        """Local coordinates z in [-1, 1] of parameters x (m,) of segments seg (m,)."""
        return local_coordinate(x, self.x0[seg], self.x1[seg])

    def roots(self, seg, row, offset, a, b, fa, fb, ztol):
        """Zeros x (k,) of series row (0 J, 1 K, 2 H) minus offset (k,) of the segments seg
        (k,), all using the interpolant, in the brackets [a, b] (x) whose values fa, fb (k,)
        differ in sign: safeguarded Newton on the power series (exact derivative), a step
        outside the bracket replaced by bisection, until a step is below ztol (in z) or
        NEWTON_STEPS; a zero bracket end is returned as it is."""
        d = self.power.shape[2]
        za, zb = self.local(a, seg), self.local(b, seg)
        neg_a = fa < 0.0
        lo, hi = np.where(neg_a, za, zb), np.where(neg_a, zb, za)  # f(lo) < 0 < f(hi)
        flo, fhi = np.where(neg_a, fa, fb), np.where(neg_a, fb, fa)
        with np.errstate(divide="ignore", invalid="ignore"):
            z = lo + np.nan_to_num(flo / (flo - fhi), nan=0.5) * (hi - lo)
        z = np.where(fa == 0.0, za, np.where(fb == 0.0, zb, z))
        act = np.nonzero((fa != 0.0) & (fb != 0.0))[0]
        # coefficient columns of f (the open brackets', first n) and of f' (its leading
        # coefficient a zero, which leaves Horner's arithmetic unchanged; last n): both in one
        # Horner pass per step, compacted as brackets close
        F = self.power[seg, row]  # (k, d), a copy
        F[:, 0] -= offset
        n = act.size
        cd = np.zeros((d, 2 * n))
        cd[:, :n] = F[act].T
        cd[:-1, n:] = cd[1:, :n] * np.arange(1, d)[:, None]
        zi, l, h = z[act], lo[act], hi[act]
        with np.errstate(divide="ignore", invalid="ignore"):
            for _ in range(NEWTON_STEPS):
                if n == 0:
                    break
                fd = horner_columns(cd, np.concatenate((zi, zi)))
                f, df = fd[:n], fd[n:]
                neg = f < 0.0
                l = np.where(neg, zi, l)
                h = np.where(neg, h, zi)
                step = f / df
                zn = zi - step
                small = np.abs(step) <= ztol  # converged (the step may round onto a bracket end)
                inside = np.isfinite(zn) & ((zn - l) * (zn - h) < 0.0)
                zn = np.where(inside | small, zn, 0.5 * (l + h))
                zero = f == 0.0
                done = small | zero | (np.abs(h - l) <= ztol)
                zi = np.where(zero, zi, zn)
                if done.any():
                    z[act[done]] = zi[done]
                    keep = ~done
                    act, zi, l, h = act[keep], zi[keep], l[keep], h[keep]
                    cd = cd[:, np.concatenate((keep, keep))]
                    n = act.size
        z[act] = zi
        return self.x0[seg] + 0.5 * (z + 1.0) * (self.x1[seg] - self.x0[seg])

    def integrals(self, seg, a, b):
        """Exact integrals over [a, b] (k,) in x of J and K J of the series of the segments
        seg (k,) (all using the interpolant): the power series' antiderivatives (K J as the
        product of the two series) at both ends. Returns two (k,) arrays."""
        if self._antiderivatives is None:  # coefficient columns (degree, segment)
            J, K = self.power[:, 0].T.copy(), self.power[:, 1].T.copy()
            self._antiderivatives = (antiderivative_columns(J), antiderivative_columns(product_columns(K, J)))
        za, zb = self.local(a, seg), self.local(b, seg)
        h = 0.5 * (self.x1[seg] - self.x0[seg])
        ends = np.concatenate((zb, za))
        seg2 = np.concatenate((seg, seg))
        k = seg.size
        vJ, vKJ = (horner_columns(A[:, seg2], ends) for A in self._antiderivatives)
        return h * (vJ[:k] - vJ[k:]), h * (vKJ[:k] - vKJ[k:])

    def window_min(self, row, offset, sign, x0, x1):
        """Least value (k,) over [x0, x1] (k,) of sign (series row - offset) (all (k,)) on every
        segment (all using the interpolant): window_min_of its power series."""
        k = np.arange(self.power.shape[0])
        return window_min_of(self.power[k, row], offset, sign, self.local(x0, k), self.local(x1, k))


def window_min_of(series, offset, sign, za, zb):
    """Least value (k,) of sign (series - offset) over [za, zb] (all (k,)) for power series
    (k, d + 1) in the local coordinate z: the least of WINDOW_SAMPLES equally spaced values,
    polished by WINDOW_STEPS Newton steps on the derivative kept in the window."""
    k = np.arange(series.shape[0])
    C = series * sign[:, None]
    C[:, 0] -= sign * offset
    lo, hi = np.minimum(za, zb), np.maximum(za, zb)
    Z = lo[:, None] + (hi - lo)[:, None] * np.linspace(0.0, 1.0, WINDOW_SAMPLES)[None, :]
    F = horner(C, Z)
    j = np.argmin(F, 1)
    z, best = Z[k, j], F[k, j]
    for _ in range(WINDOW_STEPS):
        f, d1, d2 = horner2(C, z)
        better = f < best
        best = np.where(better, f, best)
        with np.errstate(divide="ignore", invalid="ignore"):
            zn = np.clip(z - d1 / d2, lo, hi)
        z = np.where((d2 > 0.0) & np.isfinite(zn), zn, z)
    return np.minimum(best, horner(C, z))


#: Newton steps for a tangency point of a level curve of a cell's interpolant, and the
#: last step's largest size in t (local coordinate in [-1, 1]).
TANGENCY_STEPS = 12
TANGENCY_YTOL = 1e-9


def _monomial(C, cell, row, offset=None):
    """The interpolants' row of the cells cell (k,) in powers of their local coordinates,
    D (k, d + 1, d + 1) with f = sum_ij D_ij x^i y^j (D = M^T C M, M = monomial_matrix), less
    offset (k,) when given."""
    M = monomial_matrix(C.shape[-1] - 1)
    D = M.T @ C[cell, row] @ M
    if offset is not None:
        D[:, 0, 0] -= offset
    return D


def _rows_in_y(D, y):
    """The rows r_i(y) = sum_j D_ij y^j of the power series D (k, d + 1, d + 1) at y (k,), and
    their first two y derivatives: three (k, d + 1) arrays, in one Horner pass."""
    k, rows, n = D.shape
    return tuple(r.reshape(k, rows) for r in horner2(D.reshape(-1, n), np.repeat(y, rows)))


def _newton_in_box(cells, cell, s_lo, s_hi, t_lo, t_hi, s_start, t_start, stol, step):
    """Newton iterations in the cells' local coordinates (x, y) from (s_start, t_start),
    kept in the boxes [s_lo, s_hi] x [t_lo, t_hi] (patch coordinates, all (k,)): step(act,
    x, y) returns the steps dx, dy of the points act at (x, y). Returns sigma (k,) of the
    points whose last step is below stol in sigma (a scalar or (k,)) and TANGENCY_YTOL in t,
    NaN where a step failed or left the box, or TANGENCY_STEPS did not converge."""
    s0, s1 = cells.s0[cell], cells.s1[cell]
    t0, t1 = cells.t0[cell], cells.t1[cell]
    x, y = local_coordinate(s_start, s0, s1), local_coordinate(t_start, t0, t1)
    xl, xh = local_coordinate(np.minimum(s_lo, s_hi), s0, s1), local_coordinate(np.maximum(s_lo, s_hi), s0, s1)
    yl, yh = local_coordinate(np.minimum(t_lo, t_hi), t0, t1), local_coordinate(np.maximum(t_lo, t_hi), t0, t1)
    xtol = 2.0 * np.broadcast_to(stol, x.shape) / (s1 - s0)
    done = np.zeros(cell.size, bool)
    act = np.arange(cell.size)
    for _ in range(TANGENCY_STEPS):
        if act.size == 0:
            break
        xa, ya = x[act], y[act]
        with np.errstate(divide="ignore", invalid="ignore"):
            dx, dy = step(act, xa, ya)
        x[act], y[act] = xa + dx, ya + dy
        ok = np.isfinite(dx) & np.isfinite(dy)
        out = ~ok | (x[act] < xl[act]) | (x[act] > xh[act]) | (y[act] < yl[act]) | (y[act] > yh[act])
        conv = ok & ~out & (np.abs(dx) <= xtol[act]) & (np.abs(dy) <= TANGENCY_YTOL)
        x[act[out]] = np.nan
        done[act[conv]] = True
        act = act[~conv & ~out]
    x[~done] = np.nan
    return s0 + 0.5 * (x + 1.0) * (s1 - s0)


def tangency_points(C, cells, cell, row, offset, s_lo, s_hi, t_lo, t_hi, s_start, t_start, stol):
    """Points where the level curve {f_row - offset = 0} of the interpolants C (n, 3, d + 1,
    d + 1) of the cells cell (k,) is tangent to a line sigma = const: g = 0 and dg/dt = 0,
    by Newton's method on that pair of polynomial equations (the interpolant in powers of
    the cell's local coordinates, _monomial), started at (s_start, t_start) and kept in the
    boxes [s_lo, s_hi] x [t_lo, t_hi] (patch coordinates, all (k,)) (_newton_in_box).
    Returns sigma (k,) of the converged points (last step below stol in sigma, a scalar or
    (k,), and below TANGENCY_YTOL in t) and NaN where Newton failed or left its box (the
    caller's bracketed search takes those)."""
    deg = C.shape[-1] - 1
    D = _monomial(C, cell, row, offset)
    powers = np.arange(deg + 1)

    def step(act, xa, ya):
        r0, r1, r2 = _rows_in_y(D[act], ya)  # then Horner in x
        g = horner(r0, xa)
        gy = horner(r1, xa)
        gyy = horner(r2, xa)
        gx = horner(r0[:, 1:] * powers[1:], xa)
        gxy = horner(r1[:, 1:] * powers[1:], xa)
        det = gx * gyy - gy * gxy
        return (-g * gyy + gy * gy) / det, (-gx * gy + gxy * g) / det

    return _newton_in_box(cells, cell, s_lo, s_hi, t_lo, t_hi, s_start, t_start, stol, step)


def level_intersections(C, cells, cell, row1, offset1, row2, offset2, s_lo, s_hi, t_lo, t_hi,
                        s_start, t_start, stol):
    """Points where two level curves of the interpolants C (n, 3, d + 1, d + 1) of the cells
    cell (k,) meet: g1 = f_row1 - offset1 = 0 and g2 = f_row2 - offset2 = 0 (a corner of a
    class region, where a level of H meets a level of K), by Newton's method on that pair of
    polynomial equations, started at (s_start, t_start) and kept in the boxes [s_lo, s_hi] x
    [t_lo, t_hi] (as tangency_points). Returns sigma (k,) of the converged points (last step
    below stol in sigma, a scalar or (k,), and below TANGENCY_YTOL in t) and NaN where Newton
    failed or left its box."""
    deg = C.shape[-1] - 1
    D1, D2 = _monomial(C, cell, row1, offset1), _monomial(C, cell, row2, offset2)
    powers = np.arange(deg + 1)

    def step(act, xa, ya):
        n = act.size
        # both functions' rows r_i(y) and their y derivatives in one Horner pass, then x
        r0, r1, _ = horner2(np.concatenate((D1[act], D2[act])).reshape(-1, deg + 1),
                            np.tile(np.repeat(ya, deg + 1), 2))
        r0, r1 = r0.reshape(2 * n, deg + 1), r1.reshape(2 * n, deg + 1)
        x2 = np.concatenate((xa, xa))
        g, gy, gx = horner(r0, x2), horner(r1, x2), horner(r0[:, 1:] * powers[1:], x2)
        det = gx[:n] * gy[n:] - gy[:n] * gx[n:]
        return (-g[:n] * gy[n:] + g[n:] * gy[:n]) / det, (-g[n:] * gx[:n] + g[:n] * gx[n:]) / det

    return _newton_in_box(cells, cell, s_lo, s_hi, t_lo, t_hi, s_start, t_start, stol, step)


@functools.lru_cache(maxsize=None)
def bernstein_matrix(deg):
    """(deg + 1, deg + 1) matrix T: T a are the Bernstein coefficients on [-1, 1] of the power
    series sum_i a_i z^i (z = 2 s - 1, then s^j = sum_k C(k, j) / C(deg, j) B_k(s)); the
    series lies between their least and largest on [-1, 1]. Read-only, one per degree."""
    from math import comb
    n = deg
    A = np.zeros((n + 1, n + 1))  # powers of z -> powers of s
    for i in range(n + 1):
        for j in range(i + 1):
            A[j, i] = comb(i, j) * 2.0 ** j * (-1.0) ** (i - j)
    S = np.zeros((n + 1, n + 1))  # powers of s -> Bernstein
    for k in range(n + 1):
        for j in range(k + 1):
            S[k, j] = comb(k, j) / comb(n, j)
    T = S @ A
    T.flags.writeable = False
    return T


def interpolant_range(C, cell, row):
    """Bounds lo, hi (k,) of the interpolants' row (0 J, 1 K, 2 H) over their cells cell (k,):
    the least and largest tensor Bernstein coefficient (the polynomial in the cell's local
    coordinates lies in their convex hull), widened by the rounding of the conversions
    (4 (d + 1) eps times the coefficients computed from absolute values), so that the
    bounds hold in floating point too."""
    deg = C.shape[-1] - 1
    T = bernstein_matrix(deg)
    M = _monomial(C, cell, row)
    B = T @ M @ T.T
    aT = np.abs(T)
    pad = (4.0 * (deg + 1) * np.finfo(float).eps) * (aT @ np.abs(M) @ aT.T)
    return (B - pad).min((1, 2)), (B + pad).max((1, 2))


#: Grid of the search for an interpolant's extremum (per local axis), and Newton steps after it.
EXTREMUM_GRID = 9
EXTREMUM_STEPS = 6


def interpolant_extremum(C, cell, row, sign):
    """The largest value of sign * (the interpolants' row) over their cells cell (k,) (sign:
    +1 or -1, scalar or (k,)) as far as a search finds it: the best point of an
    EXTREMUM_GRID x EXTREMUM_GRID grid in the cell's local coordinates, then up to
    EXTREMUM_STEPS Newton steps on the gradient (kept where they improve the value and stay
    in [-1, 1]^2). Returns value (k,) (of the row,
    sign included) and local coordinates x, y (k,) of the point."""
    deg = C.shape[-1] - 1
    k = cell.size
    z = np.linspace(-1.0, 1.0, EXTREMUM_GRID)
    P = legendre_vander(z, deg)
    sign = np.broadcast_to(np.asarray(sign, dtype=float), (k,))
    G = sign[:, None, None] * np.einsum("ia,kab,jb->kij", P, C[cell, row], P)
    best = G.reshape(k, -1).argmax(1)
    x, y = z[best // EXTREMUM_GRID], z[best % EXTREMUM_GRID]
    val = G.reshape(k, -1)[np.arange(k), best]
    D = sign[:, None, None] * _monomial(C, cell, row)  # sum_ij D_ij x^i y^j
    pw = np.arange(deg + 1)
    for _ in range(EXTREMUM_STEPS):
        r0, r1, r2 = _rows_in_y(D, y)
        gx = horner(r0[:, 1:] * pw[1:], x)
        gy = horner(r1, x)
        gxx = horner(r0[:, 2:] * (pw[2:] * pw[1:-1]), x)
        gxy = horner(r1[:, 1:] * pw[1:], x)
        gyy = horner(r2, x)
        det = gxx * gyy - gxy * gxy
        with np.errstate(divide="ignore", invalid="ignore"):
            xn = x - (gyy * gx - gxy * gy) / det
            yn = y - (gxx * gy - gxy * gx) / det
        ok = np.isfinite(xn) & np.isfinite(yn) & (np.abs(xn) <= 1.0) & (np.abs(yn) <= 1.0)
        xn, yn = np.where(ok, xn, x), np.where(ok, yn, y)
        r = horner(D.reshape(-1, deg + 1), np.repeat(yn, deg + 1)).reshape(k, deg + 1)
        vn = horner(r, xn)
        better = ok & (vn > val)
        x, y, val = np.where(better, xn, x), np.where(better, yn, y), np.where(better, vn, val)
    return val, x, y
