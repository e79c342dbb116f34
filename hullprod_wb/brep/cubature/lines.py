"""Mixed cells integrated on lines: functions of the integration's LineSetting (pieces) and the
MixedCells, called by the driver for its candidate cells.

The class indicators are discontinuous, and |K|, max(+-K, 0) have kinks on K = 0; Gauss sums
across such curves converge only like the cell size (squared). For a parent cell with a
mixed child the K integrals and class areas are line integrals over the parent, taken on the
tensor interpolant of J, K, H through its children's samples (hullprod_wb.brep.cubature.cell_interpolant)
when the interpolant's error, measured at the parent's own nodes and propagated to each
integral, is within INTERPOLANT_SHARE of the cell's budget (it then adds to the cell's
error); a cell whose interpolant is not yet that accurate is split instead, and at the last
level its lines run on the field itself. A cell on its interpolant in an affine patch (one
constant area element) whose K varies more along sigma than along t takes its lines along
sigma instead (sigma and t exchanged, turn_cells): its level curves then cross the lines
instead of running beside them, and cross the cell's t edges far less often.

- On a line sigma = const, the crossings in t of K - tau_K, K + tau_K, H - tau_H, H + tau_H
  and K are bracketed between the samples ZS (and around extrema of one sign that get near
  zero between samples) and refined together; each piece between crossings has one class
  and one sign of K. K = 0 lies inside the band |K| <= tau_K (flat or single pieces), where
  the K integrals are at most tau_K times the area: it is refined only once the bounds
  charged instead (a piece's K integral taken with its own sign, error at most
  tau_K A - |int K J|) would exceed ZERO_CHARGE_SHARE of the K integrals' tolerances
  (near-developable surfaces), from then on.
- On a line of an interpolant (a Legendre series in t, cell_interpolant.SegmentField) the
  crossings are refined by safeguarded Newton on the series and J, K J are integrated over
  each piece exactly (antiderivatives of the series and of their product), so the line adds
  no error of its own beyond those bounds; on a line of the field the crossings are refined
  by solve_bracketed (one field call per step) and J, K J are integrated by Gauss-Kronrod
  3/7, with the integral of their interpolants at ZS as the comparison for the error
  estimate (on pieces shorter than SHORT_PIECE of the line, the interpolants, against those
  of lower degree).
- In sigma the cell is cut (cuts) and the pieces are integrated by Gauss-Kronrod 3/7 (error
  |K7 - G3|), halving those whose error does not fit, at most class_max_depth times.
- On lines of the field, the quadtree's own children sums of the K integrals bound the line
  error estimate from below where both disagree (a rough or singular integrand the lines do
  not resolve); an interpolant has passed the sharper check above.

Islands of a level curve inside a cell that no sample sees (a cell that is not mixed), or
inside a cell on the field between its lines, are not resolved.
"""

import numpy as np

from ...core.thresholds import classify
from .cell_interpolant import fit_interpolants
from .cells import greedy_accept, row_sums
from .crossings import crossings, line_segments
from .cuts import corner_cuts, edge_cuts, island_cuts, tangent_cuts
from .gauss_rules import WK, XK, kronrod_error, legendre_vander
from .patches import cluster_map
from .pieces import (Interpolants, LinePieces, LineValues, MixedCells, Pieces, count_and_pairs, cut_segments,
                     halve_pieces, split_pieces)
from .settings import (AREA, CLASS_AREAS, CLASS_ELLIPTIC, CLASS_FLAT, CLASS_SADDLE, CLASS_SINGLE, INTERPOLANT_SHARE,
                       LINE_CLASSES, LINE_K, MAX_PIECES, M_HI, M_LO, N_LEVELS, N_LINE_Q, SHORT_PIECE, SLIVER,
                       STALL_RATIO, XI3, XI9, ZERO_BOUND_SAFETY, ZERO_CHARGE_PARTS, ZS)


def interpolants(ls, parent, children, sel, units, budget):
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

    Returns Interpolants."""
    idx = np.nonzero(sel)[0]
    m = idx.size
    fit = fit_interpolants(parent, children, idx, ls.grid_inverse, ls.parent_vander)
    d, dKJ, lo, hi, reg = fit.d, fit.dKJ, fit.lo, fit.hi, fit.reg
    tk, th = ls.tau_K, ls.tau_H

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
    A = np.abs(units.Q[:, AREA])
    err = np.empty((m, N_LINE_Q))
    err[:, LINE_K] = (2.0 * units.pmeas * dKJ)[:, None]
    cls = err[:, LINE_CLASSES]
    # columns flat, single, elliptic, saddle: K = +tau_K borders elliptic, K = -tau_K
    # saddle, both border flat or single (whichever |H| allows), H = +-tau_H both
    cls[:, CLASS_FLAT] = A * (np.where(flat_ok, k_plus + k_minus, 0.0) + h_band)
    cls[:, CLASS_SINGLE] = A * (np.where(single_ok, k_plus + k_minus, 0.0) + h_band)
    cls[:, CLASS_ELLIPTIC] = A * k_plus
    cls[:, CLASS_SADDLE] = A * k_minus
    # and the interpolated J itself, in each class's area
    rel_J = d[:, 0] / np.maximum(np.abs(lo[:, 0]), 1e-300)
    cls += np.abs(units.Q[:, CLASS_AREAS]) * rel_J[:, None]
    err = np.where(reg[:, None], err, np.inf)
    use = np.all(err <= INTERPOLANT_SHARE * budget, 1)
    return Interpolants(fit.C, use, np.where(use[:, None], err, 0.0))


def line_values(ls, mc, cell, pid, sig, t0, t1, n_counted=0):
    """Lines sigma = const of patches pid over t in [t0, t1] (all (L,)), in the cells
    cell (L,) of the MixedCells mc; the last n_counted of them are not
    integrated: their crossings are only counted (crossings with refine False; their
    F, E, C are zero).

    Returns their LineValues (crossings: count_and_pairs). The pieces of a line between
    crossings have the class and the sign of K of their midpoint; unless resolve_zero is
    set, K = 0 does not cut the lines, and flat
    and single pieces take the sign of their K integral instead. On lines of an
    interpolant J and K J are integrated exactly (SegmentField.integrals, no error
    estimate of their own); on lines of the field by Gauss-Kronrod 3/7 on pieces longer
    than SHORT_PIECE of the line (error
    estimate: the difference to the integral of their degree-8 interpolants at the
    samples ZS; a line without crossings is one piece whose Kronrod nodes are samples),
    over those interpolants on shorter ones (error estimate: against the degree-6
    interpolants at the inner samples)."""
    L = pid.size
    evalf, width = line_segments(ls, mc, cell, pid, sig)
    nv = L - n_counted  # lines integrated
    li, lq, roots, S = crossings(ls, evalf, refine=np.arange(L) < nv)
    counts = count_and_pairs(li, lq, roots, L)
    v = li < nv
    ar = np.arange(nv)
    lid, a, b = cut_segments(np.concatenate((t0[:nv], roots[v], t1[:nv])), np.concatenate((ar, li[v], ar)))
    lp = _line_pieces(ls, evalf, S, lid, a, b, t0, t1)
    vals, errs = _piece_integrals(evalf, S, width, lp)
    P, Pe, charge = _piece_quantities(ls, S, lp, vals, errs)
    F, E = np.zeros((L, N_LINE_Q)), np.zeros((L, N_LINE_Q))
    F += row_sums(lid, P, L)
    E += row_sums(lid, Pe, L)
    return LineValues(F, E, np.bincount(lid, weights=charge, minlength=L), evalf.power, counts)


def _line_pieces(ls, evalf, S, lid, a, b, t0, t1):
    """The pieces [a, b] of the lines lid between crossings, sorted by kind (on an
    interpolant, whole lines and long and short pieces on the field), with the field at the
    Kronrod nodes of the long pieces (the samples of whole lines) and at the other pieces'
    midpoints (one field call), and each piece's class at its midpoint: LinePieces."""
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
    J = np.concatenate((np.where(reg, J, 0.0)[:nl * XK.size], S.J[inner].ravel(),
                        np.where(reg, J, 0.0)[nl * XK.size:]))
    Kc = np.concatenate((K[:nl * XK.size], S.K[inner].ravel(), K[nl * XK.size:]))
    Hc = np.concatenate((H[:nl * XK.size], S.H[inner].ravel(), H[nl * XK.size:]))
    rc = np.concatenate((reg[:nl * XK.size], S.reg[inner].ravel(), reg[nl * XK.size:]))
    KJ = np.where(rc, Kc * J, 0.0)
    mid = np.empty(lid.size, int)  # index of each piece's midpoint value
    kw = np.concatenate((np.nonzero(long_)[0], np.nonzero(whole)[0]))
    mid[kw] = np.arange(nl + nw) * XK.size + XK.size // 2
    mid[mp] = (nl + nw) * XK.size + np.arange(int(mp.sum()))
    cls = classify(Kc[mid], Hc[mid], ls.tau_H, ls.tau_K, rc[mid])
    return LinePieces(lid, a, b, t0, span, poly, sh, kw, nl + nw, J, KJ, Kc[mid], cls)


def _piece_integrals(evalf, S, width, lp):
    """Integrals (2, k) of J and K J over the pieces lp (LinePieces) and their error
    estimates (2, k): exact on an interpolant's line, Gauss-Kronrod 3/7 against the
    interpolant of the line's samples on long pieces and whole lines, that interpolant
    against the one of lower degree on short pieces."""
    lid, a, b, t0, span, kw, sh = lp.line, lp.a, lp.b, lp.t0, lp.span, lp.kronrod, lp.short
    vals = np.zeros((2, lid.size))
    errs = np.zeros((2, lid.size))
    if lp.poly.any():
        k = np.nonzero(lp.poly)[0]
        vals[:, k] = np.stack(evalf.integrals(lid[k], a[k], b[k])) * width[lid[k]]
    fk = np.nonzero(~lp.poly)[0]
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
        nk = lp.n_kronrod
        for row, (f, Z) in enumerate(((lp.J, S.J), (lp.KJ, S.KJ))):
            fz = Z[lf]
            interp = np.einsum("sm,sm->s", w_hi, fz)
            # long and whole pieces: Kronrod value, error estimated against the interpolant
            vk = (f[:nk * XK.size].reshape(nk, XK.size) @ WK) * scale
            vals[row, kw] = vk
            errs[row, kw] = np.abs(vk - interp[ikw])
            # short pieces: the interpolant, against the degree-6 one
            vals[row, sh] = interp[ish]
            errs[row, sh] = np.abs(interp[ish] - np.einsum("sm,sm->s", w_lo[ish], fz[ish, 1:-1]))
    return vals, errs


def _piece_quantities(ls, S, lp, vals, errs):
    """The LINE_Q integrals (k, 7) of the pieces lp from their J and K J integrals vals and
    errors errs (2, k): |K| J, max(K,0) J, max(-K,0) J by the sign of K at the midpoint (of
    the K integral for flat and single pieces while K = 0 is not resolved), J into the
    class's column; their errors, with the bound charged (k,) for unresolved sign changes."""
    lid, cls = lp.line, lp.cls
    sk = np.sign(np.where(cls >= 0, lp.K_mid, 0.0))
    charge = np.zeros(lid.size)
    if not ls.resolve_zero:
        # K = 0 not resolved: a flat or single piece (|K| <= tau_K on it) takes the sign of
        # its K integral; on a line where K changes sign, its K integrals' error is at most
        # B A - |int K J| (|K|) and half that (K+, K-), B the bound of |K| on it (tau_K,
        # or ZERO_BOUND_SAFETY times the line's largest sampled |K| when less), A its area
        soft = (cls == 0) | (cls == 1)
        sk = np.where(soft, np.sign(vals[1]), sk)
        i = np.nonzero(soft & S.zero[lid])[0]
        if i.size:
            kmax = np.where(S.reg, np.abs(S.K), 0.0).max(1)
            bound = np.minimum(ls.tau_K, ZERO_BOUND_SAFETY * kmax[lid[i]])
            charge[i] = np.maximum(bound * vals[0, i] - np.abs(vals[1, i]), 0.0)
    # per piece: |K| J, max(K,0) J, max(-K,0) J, then J into its class column
    P = np.zeros((lid.size, N_LINE_Q))
    Pe = np.zeros((lid.size, N_LINE_Q))
    for col, fac in ((0, sk), (1, np.maximum(sk, 0.0)), (2, np.minimum(sk, 0.0))):
        P[:, col] = fac * vals[1]
        Pe[:, col] = np.abs(fac) * errs[1] + ZERO_CHARGE_PARTS[col] * charge
    ok = cls >= 0
    rows = np.nonzero(ok)[0]
    P[rows, LINE_CLASSES.start + cls[ok]] = vals[0][ok]
    Pe[rows, LINE_CLASSES.start + cls[ok]] = errs[0][ok]
    return P, Pe, charge


def piece_values(ls, mc, pc, counted=True):
    """Gauss-Kronrod 3/7 in sigma over the Pieces pc of the MixedCells mc; nodes cluster_map(kind) of XI9: the Kronrod nodes, and (with
    counted) lines next to both ends whose crossings are only counted, to detect
    tangencies there (in the same line_values call).
    Slivers (pieces without clustered ends narrower than SLIVER of their cell, between
    nearby kinks such as the crossings of K = -tau_K, 0, tau_K) take the 2-point Gauss
    rule instead, with its difference to the midpoint rule as the sigma error, and no
    tangency search: three lines instead of nine.

    Returns values (n, 7), sigma error (kronrod_error) (n, 7), t error (n, 7), its
    charged part (the lines' C, line_values) (n,), and of the 9 lines: sigma (n, 9),
    count (n, 9, 5), pair (n, 9, 5, 2) (for slivers count 0 and pair NaN: no tangency
    cut), the first and last crossing of each level, ends (n, 9, 5, 2) (NaN where none),
    and the power series in t of the lines on interpolants (SegmentField.power)
    (n, 9, 3, d + 1) (without counted, those of the end lines are 0, NaN, NaN and 0)."""
    cells = mc.boxes
    n, m = pc.size, XI9.size
    cw = (cells.s1 - cells.s0)[pc.cell]
    sliver = ((pc.sb - pc.sa) < SLIVER * cw) & (pc.kind == 0)
    nk = np.nonzero(~sliver)[0]
    ns = np.nonzero(sliver)[0]
    c, dc = cluster_map(np.repeat(pc.kind[nk, None], m, 1), np.broadcast_to(XI9, (nk.size, m)))
    w = (pc.sb - pc.sa)[:, None]
    sig = np.repeat(pc.sa[:, None], m, 1) + w * XI9[None, :]
    sig[nk] = pc.sa[nk, None] + w[nk] * c
    # lines: the Kronrod nodes of the pieces, then the three nodes of the slivers, then
    # (counted only) the two end lines of the pieces
    sl = pc.sa[ns, None] + w[ns] * XI3[None, :]
    ends = sig[nk][:, [0, -1]].ravel() if counted else np.empty(0)
    ecell = np.repeat(pc.cell[nk], 2) if counted else np.empty(0, int)
    lsig = np.concatenate((sig[nk, 1:-1].ravel(), sl.ravel(), ends))
    lcell = np.concatenate((np.repeat(pc.cell[nk], m - 2), np.repeat(pc.cell[ns], XI3.size), ecell))
    lpid = cells.pid[lcell]
    nv = lsig.size - ends.size
    _, ldu = ls.patches.u_of_sigma(lpid[:nv], lsig[:nv])
    ldu = mc.turned(lcell[:nv], ldu, "du")
    d = line_values(ls, mc, lcell, lpid, lsig, cells.t0[lcell], cells.t1[lcell], n_counted=ends.size)
    nkl = nk.size * (m - 2)
    Fk, es, et = (np.zeros((n, N_LINE_Q)) for _ in range(3))
    Fc = np.zeros(n)
    if nk.size:
        wt = (w[nk] * dc[:, 1:-1] * ldu[:nkl].reshape(nk.size, m - 2))[:, :, None]
        F = d.F[:nkl].reshape(nk.size, m - 2, N_LINE_Q) * wt
        Fk[nk] = np.einsum("nkq,k->nq", F, WK)
        es[nk] = kronrod_error(F, Fk[nk])
        et[nk] = np.einsum("nkq,k->nq", d.E[:nkl].reshape(nk.size, m - 2, N_LINE_Q) * wt, WK)
        Fc[nk] = (d.C[:nkl].reshape(nk.size, m - 2) * wt[:, :, 0]) @ WK
    if ns.size:
        wt = (w[ns] * ldu[nkl:nv].reshape(ns.size, XI3.size))[:, :, None]
        F = d.F[nkl:nv].reshape(ns.size, XI3.size, N_LINE_Q) * wt
        Fk[ns] = 0.5 * (F[:, 0] + F[:, 2])
        es[ns] = np.abs(Fk[ns] - F[:, 1])
        et[ns] = 0.5 * (d.E[nkl:nv].reshape(ns.size, XI3.size, N_LINE_Q) * wt)[:, [0, 2]].sum(1)
        Fc[ns] = 0.5 * (d.C[nkl:nv].reshape(ns.size, XI3.size) * wt[:, :, 0])[:, [0, 2]].sum(1)
    count = np.zeros((n, m, N_LEVELS), int)
    pair = np.full((n, m, N_LEVELS, 2), np.nan)
    ends = np.full((n, m, N_LEVELS, 2), np.nan)
    series = np.zeros((n, m) + d.power.shape[1:])  # of the lines on interpolants
    if nk.size:
        cr = d.crossings
        count[nk, 1:-1] = cr.count[:nkl].reshape(nk.size, m - 2, -1)
        pair[nk, 1:-1] = cr.pair[:nkl].reshape(nk.size, m - 2, N_LEVELS, 2)
        ends[nk, 1:-1] = cr.ends[:nkl].reshape(nk.size, m - 2, N_LEVELS, 2)
        series[nk, 1:-1] = d.power[:nkl].reshape((nk.size, m - 2) + series.shape[2:])
    if nk.size and counted:
        e, power = d.crossings.take(slice(nv, None)), d.power[nv:]
        count[nk, 0], count[nk, -1] = e.count[0::2], e.count[1::2]
        pair[nk, 0], pair[nk, -1] = e.pair[0::2], e.pair[1::2]
        ends[nk, 0], ends[nk, -1] = e.ends[0::2], e.ends[1::2]
        series[nk, 0], series[nk, -1] = power[0::2], power[1::2]
    return Fk, es, et, Fc, sig, count, pair, ends, series


def turn_cells(ls, cells, interpolants):
    """The mixed cells with their lines turned where that suits the level curves: a cell in
    a patch whose map to (u, v) is affine (linear in sigma, constant strip bounds: the area
    element du/dsigma (hi - lo) is one constant), along which K varies more in sigma than in
    t by its interpolant (the level curves run along t, so lines sigma = const would meet
    them at small angles and cross the cell's t edges, each crossing a cut; a layer along t
    would need many such lines across it) is given with sigma and t exchanged: the box, its
    interpolant's axes, and the constant width and du/dsigma of the original (NaN for the
    others, see MixedCells.turned). Lines of the field of a turned cell evaluate it with the
    axes exchanged back (crossings.field_at). The line integrals of a cell do not depend on
    the direction of its lines. cells: CellSet (its boxes used); interpolants: their
    Interpolants (fitted also where the lines do not use them). Returns MixedCells."""
    n = cells.size
    P = ls.patches
    pid = cells.pid
    affine = (P.umap[pid] == 0) & (P.lo_piece[pid] < 0) & (P.hi_piece[pid] < 0)
    cand = np.nonzero(affine & np.isfinite(interpolants.C[:, 1]).all((1, 2)))[0]
    turn = np.zeros(n, bool)
    if cand.size:
        # mean |dK| along each local axis from the K series: sum over the other axis of
        # |coefficients| times the derivative sizes of P_a (a (a + 1) / 2 at the ends)
        Ck = np.abs(interpolants.C[cand, 1])
        dsize = np.arange(Ck.shape[-1]) * (np.arange(Ck.shape[-1]) + 1) / 2.0
        d_sigma = (Ck.sum(2) * dsize).sum(1)
        d_t = (Ck.sum(1) * dsize).sum(1)
        turn[cand] = d_sigma > d_t
    boxes = cells.boxes()
    width = np.full(n, np.nan)
    du_const = np.full(n, np.nan)
    if not turn.any():
        return MixedCells(boxes, width, du_const, interpolants)
    k = np.nonzero(turn)[0]
    u, du = P.u_of_sigma(pid[k], np.full(k.size, 0.5))
    lo, hi = P.bounds(pid[k], u)
    width[k], du_const[k] = hi - lo, du
    s0, s1, t0, t1 = boxes.s0.copy(), boxes.s1.copy(), boxes.t0.copy(), boxes.t1.copy()
    s0[k], t0[k] = boxes.t0[k], boxes.s0[k]
    s1[k], t1[k] = boxes.t1[k], boxes.s1[k]
    boxes = boxes.with_(s0=s0, s1=s1, t0=t0, t1=t1)
    C = interpolants.C.copy()
    C[k] = np.swapaxes(C[k], 2, 3)
    return MixedCells(boxes, width, du_const, Interpolants(C, interpolants.use, interpolants.err))


def integrate_lines(ls, mc, budget):
    """LINE_Q integrals (n, 7), error estimates (n, 7), fit flags (n,) and the part of
    the |K| integral's error estimate charged for unresolved sign changes of K (n,)
    (line_values) of the MixedCells mc (turn_cells) with their error budgets (n, 7).

    Each cell is cut in sigma at its edge crossings and, as they are found, at
    tangencies of level curves (with a clustered map at those ends, as the square-root
    behaviour there requires); the pieces are integrated by Gauss-Kronrod, and those
    whose error has a dominant sigma part and does not fit are halved, at most
    class_max_depth times. Pieces are accepted greedily against the summed budgets of
    the cells; a cell stops early once its accepted and current errors fit its budget,
    or once its accepted errors exceed it, two halves keep more than STALL_RATIO of their
    parent's error, or it holds MAX_PIECES pieces (a singular or rough integrand). A cell
    fits when its total error estimate is within its budget."""
    nc = mc.size
    out, errs, charged = np.zeros((nc, N_LINE_Q)), np.zeros((nc, N_LINE_Q)), np.zeros(nc)
    ec, es = edge_cuts(ls, mc)
    ar = np.arange(nc)
    cell, sa, sb = cut_segments(np.concatenate((mc.boxes.s0, es, mc.boxes.s1)),
                                np.concatenate((ar, ec, ar)))
    pc = Pieces.whole(cell, sa, sb)
    left = budget - mc.interp.err
    for level in range(ls.class_max_depth + 1):
        last = level == ls.class_max_depth
        # the end lines' counts serve the tangency search only, which the last level skips
        F, e_s, e_t, e_c, sig, count, pair, ends, series = piece_values(ls, mc, pc, counted=not last)
        if last:
            tp, ts = np.empty(0, int), None
        else:  # tangencies, and corners where a level of H meets a level of K
            tp, ts = tangent_cuts(ls, mc, pc, sig, count, pair, series)
            cp, cs = corner_cuts(ls, mc, pc, sig, count, ends, series)
            tp, ts = np.concatenate((tp, cp)), np.concatenate((ts, cs))
            if level == 0:  # and islands of a class that no line of a cell meets
                ip, is_ = island_cuts(ls, mc, pc, F)
                tp, ts = np.concatenate((tp, ip)), np.concatenate((ts, is_))
        cut = np.zeros(pc.size, bool)
        cut[tp] = True
        c = pc.cell
        err = e_s + e_t
        with np.errstate(divide="ignore", invalid="ignore"):
            enorm = np.nan_to_num(err / budget[c], nan=0.0).max(1)
        # halves whose errors together did not fall below STALL_RATIO of their parent's
        sib = pc.sib
        halves = sib >= 0
        pair_sum = np.bincount(sib[halves], weights=enorm[halves], minlength=cut.size)
        stalled = np.zeros(nc, bool)
        stalled[c[halves & (pair_sum[np.maximum(sib, 0)] > STALL_RATIO * pc.perr)]] = True
        total = budget - left
        total += row_sums(c, err, nc)
        fits = np.all(total <= budget, 1) & (np.bincount(c[cut], minlength=nc) == 0)
        give_up = stalled | np.any(left < 0.0, 1) | (np.bincount(c, minlength=nc) >= MAX_PIECES)
        done = np.ones(cut.size, bool) if last else ~cut & (
            fits[c] | give_up[c] | greedy_accept(err, left.sum(0)) | np.all(e_s <= e_t, 1))
        out += row_sums(c[done], F[done], nc)
        errs += row_sums(c[done], err[done], nc)
        charged += np.bincount(c[done], weights=e_c[done], minlength=nc)
        left -= row_sums(c[done], err[done], nc)
        halve = ~done & ~cut
        pc = Pieces.concatenate([split_pieces(pc, tp, ts), halve_pieces(pc, halve, enorm)])
        if pc.size == 0:
            break
    errs += mc.interp.err
    return out, errs, np.all(errs <= budget, 1), charged
