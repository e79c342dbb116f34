"""Where the level curves of K and H cross the lines of mixed cells: the field or the
interpolant along lines (line_segments, cell_field) and the zeros of the five level
functions K -+ tau_K, H -+ tau_H, K along them (crossings), used by the line integration
(lines) and the cut search (cuts)."""
import numpy as np

from .cell_interpolant import SegmentField, cell_values
from .pieces import LineSamples, parabolic_min
from .roots import solve_bracketed
from .settings import CROSSING_RTOL, CROSSING_STEPS, DIP_FRACTION, LEVEL_ROW, N_LEVELS, ZS


def field_at(ls, mc, cell, sig, t):
    """The field (J, K, H, regular) at the patch coordinates (sig, t) (m,) of the cells cell
    (m,) of the MixedCells mc, in their own axes: a turned cell (lines.turn_cells, in a
    patch with u affine in sigma and constant bounds) has sigma and t exchanged."""
    P = ls.patches
    pid = mc.boxes.pid[cell]
    turned = ~np.isnan(mc.width[cell])
    s_, t_ = np.where(turned, t, sig), np.where(turned, sig, t)
    u, _ = P.u_of_sigma(pid, s_)
    lo, hi = P.bounds(pid, u)
    return ls.field(u, lo + t_ * (hi - lo))


def line_segments(ls, mc, cell, pid, sig):
    """SegmentField of the lines sigma = sig (L,) of patches pid (L,) in the cells cell
    (L,) of the MixedCells mc, and the lines' strip widths hi - lo (L,) (the constant of
    turned cells: MixedCells.turned); the field is evaluated where no interpolant is used."""
    u, _ = ls.patches.u_of_sigma(pid, sig)
    lo, hi = ls.patches.bounds(pid, u)
    width = mc.turned(cell, hi - lo, "width")
    # a turned cell's line runs along sigma at v = lo + sig width (its bounds are constants)
    turned = ~np.isnan(mc.width[cell])
    some_turned = bool(turned.any())

    def line(x, i):
        uu, vv = u[i], lo[i] + x * width[i]
        if some_turned:
            k = np.nonzero(turned[i])[0]
            uu[k] = ls.patches.u_of_sigma(pid[i[k]], x[k])[0]
            vv[k] = lo[i[k]] + sig[i[k]] * width[i[k]]
        return ls.field(uu, vv)

    evalf = SegmentField(mc.interp.C, mc.interp.use, mc.boxes, cell, sig, "t", line)
    return evalf, width


def cell_field(ls, mc, cell, sig, t):
    """J, K, H, regular (m,) at patch coordinates (sig, t) (m,) of the cells cell (m,) of
    the MixedCells mc: the interpolant where the cell uses one, else the field."""
    cells, interp = mc.boxes, mc.interp
    cell = np.asarray(cell).ravel()
    sig, t = np.broadcast_to(sig, cell.shape).ravel(), np.broadcast_to(t, cell.shape).ravel()
    J, K, H = np.empty(cell.size), np.empty(cell.size), np.empty(cell.size)
    reg = np.ones(cell.size, bool)
    use = interp.use[cell]
    i = np.nonzero(use)[0]
    if i.size:
        J[i], K[i], H[i] = cell_values(interp.C, cells, cell[i], sig[i], t[i])
    i = np.nonzero(~use)[0]
    if i.size:
        J[i], K[i], H[i], reg[i] = field_at(ls, mc, cell[i], sig[i], t[i])
    return J, K, H, reg


def crossings(ls, evalf, refine=True):
    """Zeros of the five level functions along the segments of evalf, x in [x0, x1] (n,)
    (evalf.x0, evalf.x1); ls: the integration's LineSetting.

    evalf(x, i) -> (J, K, H, regular) (m,) each, at parameters x (m,) of segments i (m,),
    and evalf.samples(zs) at the fractions zs (k,) of every segment (a SegmentField).
    Brackets: sign changes between the samples at ZS, and, where three samples of one
    sign dip towards zero and their parabola's vertex gets within DIP_FRACTION of zero,
    the two sides of the extremum (parabolic_min) when it has the other sign. Levels of
    H only matter where |K| <= tau_K and are skipped elsewhere. The brackets are refined
    together (one field call per step of solve_bracketed). refine=False only counts crossings
    (approximate positions from the samples, no further field calls). Returns segment
    index (k,), level index (k,), x (k,), and the samples (LineSamples; zero: K changes
    sign on the segment by the samples, a sign change or a dip of K towards zero). Crossings of K = 0
    (level 4) are refined and returned only while resolve_zero is set (see lines.line_values).
    refine may also be an (n,) bool array: per segment."""
    n = evalf.x0.size
    refine = np.broadcast_to(np.asarray(refine, bool), (n,))
    xs, G, S, near, change = _sampled_levels(ls, evalf)
    li, j, q = np.nonzero(change)
    a, b, fa, fb = xs[li, j], xs[li, j + 1], G[li, j, q], G[li, j + 1, q]

    def g(x, idx, seg, lev):
        _, Kx, Hx, rx = evalf(x, seg[idx])
        return np.where(rx, ls.thresholds(Kx, Hx)[np.arange(idx.size), lev[idx]], np.nan)

    dips, counted = _dips(ls, xs, G, near, S, refine)
    if dips is not None:
        pi, pq, sg, lo_, mid, hi_, y0, y1, y2 = dips
        xe, fe = parabolic_min(lambda x, idx: sg[idx] * g(x, idx, pi, pq),
                               np.stack((lo_, mid, hi_), 1),
                               sg[:, None] * np.stack((y0, y1, y2), 1))
        hit = np.nonzero(fe < 0.0)[0]
        fe = sg[hit] * fe[hit]
        li = np.concatenate((li, pi[hit], pi[hit]))
        q = np.concatenate((q, pq[hit], pq[hit]))
        a = np.concatenate((a, lo_[hit], xe[hit]))
        b = np.concatenate((b, xe[hit], hi_[hit]))
        fa = np.concatenate((fa, y0[hit], fe))
        fb = np.concatenate((fb, fe, y2[hit]))
    roots = _bracket_roots(ls, evalf, g, li, q, a, b, fa, fb, refine)
    li = np.concatenate((li, counted[0], counted[0]))
    q = np.concatenate((q, counted[1], counted[1]))
    return li, q, np.concatenate((roots, counted[2])), S


def _sampled_levels(ls, evalf):
    """The level functions at the samples ZS of the segments of evalf: the samples' x (n, 9),
    the level values G (n, 9, 5) (NaN where not regular), the LineSamples (zero set), where
    |K| <= tau_K (n, 9) (H matters), and the sign changes between neighbouring samples
    (n, 8, 5) of the levels that matter (K = 0 only while resolve_zero)."""
    x0, x1 = evalf.x0, evalf.x1
    n, m = x0.size, ZS.size
    xs = x0[:, None] + (x1 - x0)[:, None] * ZS[None, :]
    J, K, H, reg = evalf.samples(ZS)
    G = ls.thresholds(K, H)
    KJ = K * J
    every = reg.all()  # the usual case: the masks below change nothing
    if not every:
        G[~reg] = np.nan
        J, KJ = np.where(reg, J, 0.0), np.where(reg, KJ, 0.0)
    G = G.reshape(n, m, N_LEVELS)
    S = LineSamples(J.reshape(n, m), KJ.reshape(n, m), K.reshape(n, m), H.reshape(n, m), reg.reshape(n, m))
    near = (np.abs(K if every else np.where(reg, K, np.inf)) <= ls.tau_K).reshape(n, m)  # H matters
    pos = G > 0.0
    change = pos[:, :-1] != pos[:, 1:]
    if not (every and np.isfinite(K).all() and np.isfinite(H).all()):
        fin = np.isfinite(G)
        change &= fin[:, :-1] & fin[:, 1:]
    k_change = change[:, :, :2].any(2) | change[:, :, 4]
    h_ok = near[:, :-1] | near[:, 1:] | k_change
    change[:, :, 2:4] &= h_ok[:, :, None]
    S.zero = change[:, :, 4].any(1)  # K changes sign between samples
    change[:, :, 4] &= ls.resolve_zero
    return xs, G, S, near, change


def _dips(ls, xs, G, near, S, refine):
    """Two crossings between neighbouring samples: three samples of one sign that dip
    towards zero, with their parabola's vertex within DIP_FRACTION of zero. Returns the dips
    of refined segments to search (segment, level, sign, the three x and the three values,
    each (k,); None when there are none) and, of segments only counted, the parabola's roots
    (segment, level, x) of every dip whose vertex is beyond zero. S.zero is set where K dips."""
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
    S.zero[pi[cand[z4]]] = True
    if not ls.resolve_zero:
        cand = cand[~z4]
    # segments only counted: every dip whose parabola's vertex is beyond zero, the
    # parabola's roots for its two crossings
    with np.errstate(invalid="ignore", divide="ignore"):
        cross = np.nonzero(~refine[pi] & (sg * vert < 0.0) & (ls.resolve_zero | (pq != 4)))[0]
        half = np.sqrt(np.maximum(-vert[cross] / c2[cross], 0.0))
    counted = (pi[cross], pq[cross], np.concatenate((xv[cross] - half, xv[cross] + half)))
    cand = cand[refine[pi[cand]]]
    if not cand.size:
        return None, counted
    return (pi[cand], pq[cand], sg[cand], x_0[cand], x_1[cand], x_2[cand], y0[cand], y1[cand], y2[cand]), counted


def _bracket_roots(ls, evalf, g, li, q, a, b, fa, fb, refine):
    """Roots (k,) of the levels q in the brackets [a, b] (values fa, fb) of the segments li:
    regula falsi positions on segments only counted, Newton on the power series of an
    interpolant's segment, bracketed steps of g on the field elsewhere."""
    roots = np.empty(li.size)
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
        roots[i] = evalf.roots(li[i], LEVEL_ROW[q[i]], ls.level_offset[q[i]], a[i], b[i],
                               fa[i], fb[i], 2.0 * CROSSING_RTOL)
    i = np.nonzero(~poly & ~fixed)[0]
    if i.size:
        x0, x1 = evalf.x0, evalf.x1
        roots[i] = solve_bracketed(lambda x, k: g(x, i[k], li, q), a[i], b[i], fa[i], fb[i],
                                   CROSSING_RTOL * (x1 - x0)[li[i]], maxiter=CROSSING_STEPS)
    return roots
