"""Mixed cells integrated on lines (the LineIntegration part of cubature.driver._Integrator).

The class indicators are discontinuous, and |K|, max(+-K, 0) have kinks on K = 0; Gauss sums
across such curves converge only like the cell size (squared). For a parent cell with a
mixed child the K integrals and class areas are line integrals over the parent, taken on the
tensor interpolant of J, K, H through its children's samples (hullprod_wb.brep.cubature.cell_interpolant)
when the interpolant's error, measured at the parent's own nodes and propagated to each
integral, is within INTERPOLANT_SHARE of the cell's budget (it then adds to the cell's
error); a cell whose interpolant is not yet that accurate is split instead, and at the last
level its lines run on the field itself. A cell on its interpolant in an affine patch (one
constant area element) whose K varies more along sigma than along t takes its lines along
sigma instead (sigma and t exchanged, _turn_cells): its level curves then cross the lines
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
from .cell_interpolant import SegmentField, cell_values, fit_interpolants
from .gauss_rules import WK, XK, kronrod_error, legendre_vander
from .patches import cluster_map
from .roots import solve_bracketed
from .cells import _greedy_accept, _row_sums
from .pieces import (Interpolants, LineSamples, LineValues, MixedCells, Pieces, _count_and_pairs, _halve_pieces,
                     _parabolic_min, _segments, _split_pieces)
from .settings import (AREA, CLASS_AREAS, CLASS_ELLIPTIC, CLASS_FLAT, CLASS_SADDLE, CLASS_SINGLE, CROSSING_RTOL,
                       CROSSING_STEPS, DIP_FRACTION, INTERPOLANT_SHARE, LEVEL_ROW, LINE_CLASSES, LINE_K, MAX_PIECES,
                       M_HI, M_LO, N_LEVELS, N_LINE_Q, SHORT_PIECE, SLIVER, STALL_RATIO, XI3, XI9,
                       ZERO_BOUND_SAFETY, ZERO_CHARGE_PARTS, ZS)


class LineIntegration:
    """Mixed-cell line integration of the cubature's integrator (mixed into
    driver._Integrator, whose state the methods use)."""

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

        Returns Interpolants."""
        idx = np.nonzero(sel)[0]
        m = idx.size
        fit = fit_interpolants(parent, children, idx, self._grid_inverse, self._parent_vander)
        d, dKJ, lo, hi, reg = fit.d, fit.dKJ, fit.lo, fit.hi, fit.reg
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

    def _segments_t(self, mc, cell, pid, sig):
        """SegmentField of the lines sigma = sig (L,) of patches pid (L,) in the cells cell
        (L,) of the MixedCells mc, and the lines' strip widths hi - lo (L,) (the constant of
        turned cells: MixedCells.turned); the field is evaluated where no interpolant is used."""
        u, _ = self.patches.u_of_sigma(pid, sig)
        lo, hi = self.patches.bounds(pid, u)
        width = mc.turned(cell, hi - lo, "width")
        evalf = SegmentField(mc.interp.C, mc.interp.use, mc.boxes, cell, sig, "t",
                             lambda x, i: self.f(u[i], lo[i] + x * width[i]))
        return evalf, width

    def _cell_field(self, mc, cell, sig, t):
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
            pid = cells.pid[cell[i]]
            u, _ = self.patches.u_of_sigma(pid, sig[i])
            lo, hi = self.patches.bounds(pid, u)
            J[i], K[i], H[i], reg[i] = self.f(u, lo + t[i] * (hi - lo))
        return J, K, H, reg

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
        index (k,), level index (k,), x (k,), and the samples (LineSamples; zero: K changes
        sign on the segment by the samples, a sign change or a dip of K towards zero). Crossings of K = 0
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
        S = LineSamples(J.reshape(n, m), KJ.reshape(n, m), K.reshape(n, m), H.reshape(n, m), reg.reshape(n, m))
        near = (np.abs(K if every else np.where(reg, K, np.inf)) <= self.tau_K).reshape(n, m)  # H matters
        pos = G > 0.0
        change = pos[:, :-1] != pos[:, 1:]
        if not (every and np.isfinite(K).all() and np.isfinite(H).all()):
            fin = np.isfinite(G)
            change &= fin[:, :-1] & fin[:, 1:]
        k_change = change[:, :, :2].any(2) | change[:, :, 4]
        h_ok = near[:, :-1] | near[:, 1:] | k_change
        change[:, :, 2:4] &= h_ok[:, :, None]
        S.zero = change[:, :, 4].any(1)  # K changes sign between samples
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
        S.zero[pi[cand[z4]]] = True
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

    def _line_values(self, mc, cell, pid, sig, t0, t1, n_counted=0):
        """Lines sigma = const of patches pid over t in [t0, t1] (all (L,)), in the cells
        cell (L,) of the MixedCells mc; the last n_counted of them are not
        integrated: their crossings are only counted (_crossings with refine False; their
        F, E, C are zero).

        Returns their LineValues (crossings: _count_and_pairs). The pieces of a line between
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
        evalf, width = self._segments_t(mc, cell, pid, sig)
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
            for row, (f, Z) in enumerate(((J, S.J), (KJ, S.KJ))):
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
            i = np.nonzero(soft & S.zero[lid])[0]
            if i.size:
                kmax = np.where(S.reg, np.abs(S.K), 0.0).max(1)
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
        P[rows, LINE_CLASSES.start + cls[ok]] = vals[0][ok]
        Pe[rows, LINE_CLASSES.start + cls[ok]] = errs[0][ok]
        F, E = np.zeros((L, N_LINE_Q)), np.zeros((L, N_LINE_Q))
        F += _row_sums(lid, P, L)
        E += _row_sums(lid, Pe, L)
        return LineValues(F, E, np.bincount(lid, weights=charge, minlength=L), evalf.power, counts)

    def _piece_values(self, mc, pc, counted=True):
        """Gauss-Kronrod 3/7 in sigma over the Pieces pc of the MixedCells mc; nodes cluster_map(kind) of XI9: the Kronrod nodes, and (with
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
        _, ldu = self.patches.u_of_sigma(lpid[:nv], lsig[:nv])
        ldu = mc.turned(lcell[:nv], ldu, "du")
        d = self._line_values(mc, lcell, lpid, lsig, cells.t0[lcell], cells.t1[lcell], n_counted=ends.size)
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

    def _turn_cells(self, cells, interpolants):
        """The mixed cells with their lines turned where that suits the level curves: a cell
        on its interpolant, in a patch whose map to (u, v) is affine (linear in sigma, constant
        strip bounds: the area element du/dsigma (hi - lo) is one constant), along which K
        varies more in sigma than in t (the level curves run along t, so lines sigma = const
        would meet them at small angles and cross the cell's t edges, each crossing a cut) is
        given with sigma and t exchanged: the box, its interpolant's axes, and the constant
        width and du/dsigma of the original (NaN for the others, see MixedCells.turned). The
        line integrals of a cell do not depend on the direction of its lines. cells: CellSet
        (its boxes used); interpolants: their Interpolants. Returns MixedCells."""
        n = cells.size
        P = self.patches
        pid = cells.pid
        affine = (P.umap[pid] == 0) & (P.lo_piece[pid] < 0) & (P.hi_piece[pid] < 0)
        cand = np.nonzero(interpolants.use & affine)[0]
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

    def _lines(self, mc, budget):
        """LINE_Q integrals (n, 7), error estimates (n, 7), fit flags (n,) and the part of
        the |K| integral's error estimate charged for unresolved sign changes of K (n,)
        (_line_values) of the MixedCells mc (_turn_cells) with their error budgets (n, 7).

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
        ec, es = self._edge_cuts(mc)
        ar = np.arange(nc)
        cell, sa, sb = _segments(np.concatenate((mc.boxes.s0, es, mc.boxes.s1)),
                                 np.concatenate((ar, ec, ar)))
        pc = Pieces.whole(cell, sa, sb)
        left = budget - mc.interp.err
        for level in range(self.class_max_depth + 1):
            last = level == self.class_max_depth
            # the end lines' counts serve the tangency search only, which the last level skips
            F, e_s, e_t, e_c, sig, count, pair, ends, series = self._piece_values(mc, pc, counted=not last)
            if last:
                tp, ts = np.empty(0, int), None
            else:  # tangencies, and corners where a level of H meets a level of K
                tp, ts = self._tangent_cuts(mc, pc, sig, count, pair, series)
                cp, cs = self._corner_cuts(mc, pc, sig, count, ends, series)
                tp, ts = np.concatenate((tp, cp)), np.concatenate((ts, cs))
                if level == 0:  # and islands of a class that no line of a cell meets
                    ip, is_ = self._island_cuts(mc, pc, F)
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
            pc = Pieces.concatenate([_split_pieces(pc, tp, ts), _halve_pieces(pc, halve, enorm)])
            if pc.size == 0:
                break
        errs += mc.interp.err
        return out, errs, np.all(errs <= budget, 1), charged
