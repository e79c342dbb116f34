"""Where the lines of a mixed cell are cut in sigma (functions of the integration's
LineSetting, the MixedCells and their Pieces, called by lines.integrate_lines): where level
curves cross its t edges (kinks of the line values), where they are tangent to the lines (found between lines whose crossing counts
differ; square-root ends, so those pieces get a clustered map), and, on interpolants, at
the corners of the flat region, where a level of H meets one of K (found where H -+ tau_H
changes sign along a crossing of K = +-tau_K between lines, then by Newton on the pair of
level equations; kinks of the class areas' line integrals, and the only trace of a flat
region that lies between two lines), and through islands of a class that no line of an
interpolant's cell meets (where the lines miss a part that the interpolant's Bernstein
bounds allow, the extremum of K is searched)."""
import numpy as np

from .cell_interpolant import (SegmentField, horner, interpolant_extremum, interpolant_range, level_intersections,
                               local_coordinate, tangency_points, window_min_of)
from .roots import solve_bracketed
from .cells import row_sums
from .crossings import cell_field, crossings, field_at
from .pieces import inside_pieces, parabolic_min
from .settings import (CLASS_ELLIPTIC, CLASS_FLAT, CLASS_SADDLE, CLASS_SINGLE, INSIDE, LEVEL_H, LEVEL_K, LEVEL_ROW,
                       LINE_CLASSES, TANGENT_RTOL, TANGENT_STEPS)


def edge_cuts(ls, mc):
    """sigma (k,) where level curves cross the edges t = t0 and t = t1 of the MixedCells
    mc, and the cell (k,) of each: the line values have a kink there."""
    cells = mc.boxes
    pid = cells.pid
    n = pid.size
    E = np.concatenate((np.arange(n), np.arange(n)))
    h = INSIDE * (cells.t1 - cells.t0)
    tE = np.concatenate((cells.t0 + h, cells.t1 - h))

    def fallback(x, i):  # edge lines t = tE of the cells, sigma = x
        return field_at(ls, mc, E[i], x, tE[i])

    evalf = SegmentField(mc.interp.C, mc.interp.use, cells, E, tE, "sigma", fallback)
    li, _, roots, _ = crossings(ls, evalf)
    return E[li], roots


def tangent_cuts(ls, mc, pc, sig, count, pair, series):
    """sigma (k,) and piece (k,) of the Pieces pc of the MixedCells mc where a level curve is tangent to the lines sigma =
    const, between neighbouring lines of a piece whose crossing counts differ.

    With h = s g_q (s the sign making h < 0 between the closest crossing pair on the
    line with more crossings), phi(sigma) = min of h along the line over a window about
    that pair (on an interpolant's line from its series, SegmentField.window_min; on the
    field by parabolic_min) has a simple root at the tangency. Where phi changes sign
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
    cells = mc.boxes
    cell = pc.cell[p]
    t0, t1 = cells.t0[cell], cells.t1[cell]
    gap = tb - ta
    w0 = np.maximum(ta - gap, t0)
    w1 = np.minimum(tb + gap, t1)

    def level(sg, t, i):
        _, K, H, reg = cell_field(ls, mc, cell[i], sg, t)
        return np.where(reg, ls.thresholds(K, H)[np.arange(i.size), q[i]], np.nan)

    sm = sig[p, more]
    sign = -np.sign(level(sm, 0.5 * (ta + tb), np.arange(p.size)))

    use = mc.interp.use[cell]
    row, offset = LEVEL_ROW[q], ls.level_offset[q]

    def phi(sg, i, line=None):
        """min over the window of sign * g_q on the lines sg: on an interpolant's line
        from its series in t (the piece's line line when given, else made here), else
        by parabolic steps."""
        out = np.empty(i.size)
        k = np.nonzero(use[i])[0]
        if k.size:
            ik = i[k]
            if line is None:
                seg = SegmentField(mc.interp.C, mc.interp.use, cells, cell[ik], sg[k], "t", None)
                out[k] = seg.window_min(row[ik], offset[ik], sign[ik], w0[ik], w1[ik])
            else:
                c0, c1 = cells.t0[cell[ik]], cells.t1[cell[ik]]
                out[k] = window_min_of(series[p[ik], line[k], row[ik]], offset[ik], sign[ik],
                                       local_coordinate(w0[ik], c0, c1), local_coordinate(w1[ik], c0, c1))
        k = np.nonzero(~use[i])[0]
        if k.size:
            ik, sk = i[k], sg[k]
            x3 = np.stack((w0[ik], 0.5 * (ta + tb)[ik], w1[ik]), 1)
            f3 = np.repeat(sign[ik], 3) * level(np.repeat(sk, 3), x3.ravel(), np.repeat(ik, 3))
            out[k] = parabolic_min(lambda t, m: sign[ik[m]] * level(sk[m], t, ik[m]), x3,
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
    w = (pc.sb - pc.sa)[p[i]]
    root = _tangency_roots(mc, phi, i, w, cell, use, row, offset, (sm, so), (fm, fo), (w0, w1), 0.5 * (ta + tb))
    inside = inside_pieces(pc, p[i], root)
    return p[i][inside], root[inside]


def _tangency_roots(mc, phi, i, w, cell, use, row, offset, lines, values, window, start):
    """sigma (k,) of the tangencies i between the lines (sm, so) where phi (values fm, fo)
    changes sign: on an interpolant by Newton on g = dg/dt = 0 from the closer pair's
    midpoint start, by the bracketed search on phi where that fails and on the field; w (k,)
    the pieces' widths, window (w0, w1) the windows in t about the pairs."""
    (sm, so), (fm, fo), (w0, w1) = lines, values, window
    cells = mc.boxes
    root = np.full(i.size, np.nan)
    k = np.nonzero(use[i])[0]
    if k.size:
        ik = i[k]
        root[k] = tangency_points(mc.interp.C, cells, cell[ik], row[ik], offset[ik], sm[ik], so[ik],
                                  w0[ik], w1[ik], sm[ik], start[ik], TANGENT_RTOL * w[k])
    k = np.nonzero(np.isnan(root))[0]
    if k.size:
        root[k] = solve_bracketed(lambda x, m: phi(x, i[k[m]]), sm[i[k]], so[i[k]], fm[i[k]], fo[i[k]],
                                  TANGENT_RTOL * w[k], maxiter=TANGENT_STEPS)
    return root


def corner_cuts(ls, mc, pc, sig, count, ends, series):
    """sigma (k,) and piece (k,) of the Pieces pc of the MixedCells mc where a level curve of H (H = +-tau_H) meets one of K
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
    cells = mc.boxes
    cell = pc.cell
    deg = series.shape[-1] - 1
    # pieces on an interpolant, K levels (0, 1) crossed as often (once or twice) on all
    # of their lines, and whether a second crossing is there
    ck = count[:, :, :2]
    ok = mc.interp.use[cell][:, None] & np.all(ck == ck[:, :1], 1) & (ck[:, 0] >= 1) & (ck[:, 0] <= 2)
    ok = np.stack((ok, ok & (ck[:, 0] == 2)), -1)  # (n, K level, first or last crossing)
    p = np.nonzero(ok.any((1, 2)))[0]
    if p.size == 0:
        return p, np.empty(0)
    tk = ends[p][:, :, LEVEL_K, :]  # (m, 9 lines, K level, end)
    z = local_coordinate(tk, cells.t0[cell[p], None, None, None], cells.t1[cell[p], None, None, None])
    Hs = np.repeat(series[p, :, 2, None, :], 4, axis=2)  # each line's H series, for its 4 crossings
    H = horner(Hs.reshape(-1, deg + 1), z.reshape(-1)).reshape(tk.shape)
    # psi (m, 9, K level, end, H level): g_H at the K crossings, its sign changes between lines
    psi = H[..., None] - ls.level_offset[LEVEL_H]
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
    root = level_intersections(mc.interp.C, cells, c, LEVEL_ROW[qh], ls.level_offset[qh],
                               LEVEL_ROW[qk], ls.level_offset[qk], sa, sb, cells.t0[c], cells.t1[c],
                               s_start, t_start, TANGENT_RTOL * (pc.sb - pc.sa)[p])
    inside = inside_pieces(pc, p, root)
    return p[inside], root[inside]


def island_cuts(ls, mc, pc, F):
    """sigma (k,) and piece (k,) of the Pieces pc of the MixedCells mc through islands of a class inside cells on an
    interpolant that none of the cell's lines meets (first level: the pieces pc cover
    their cells; F (n, 7) their line integrals): where the lines find no elliptic part
    but the interpolant's K may exceed tau_K (its Bernstein bounds,
    cell_interpolant.interpolant_range), or no saddle part and K may fall below -tau_K,
    or only one of them and no band |K| <= tau_K while K may enter it, the extremum of K
    is searched (interpolant_extremum); where it lies beyond the level, the piece through
    it is cut at its sigma, so that the next level's lines next to the cut cross the
    island (and find its tangencies)."""
    cells = mc.boxes
    use = mc.interp.use
    nc = use.size
    area = row_sums(pc.cell, F[:, LINE_CLASSES], nc)
    ell, sad = area[:, CLASS_ELLIPTIC] > 0.0, area[:, CLASS_SADDLE] > 0.0
    band = area[:, CLASS_FLAT] + area[:, CLASS_SINGLE] > 0.0
    tk = ls.tau_K
    c = np.nonzero(use & ~(ell & sad & band))[0]
    if c.size == 0:
        return np.empty(0, int), np.empty(0)
    lo, hi = interpolant_range(mc.interp.C, c, 1)
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
    val, x, _ = interpolant_extremum(mc.interp.C, cell, 1, sign)
    hit = np.where(strict, val > bound, val >= bound)
    cell, x = cell[hit], x[hit]
    if cell.size == 0:
        return np.empty(0, int), np.empty(0)
    at = cells.s0[cell] + 0.5 * (x + 1.0) * (cells.s1[cell] - cells.s0[cell])
    # the piece of each cell that holds the point, away from its ends
    i, p = np.nonzero(pc.cell[None, :] == cell[:, None])
    inside = inside_pieces(pc, p, at[i])
    return p[inside], at[i][inside]
