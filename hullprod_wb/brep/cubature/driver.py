"""The refinement of the cubature: quadtree levels over the patches, acceptance of cells
against the error budget, the point budget, and integrate().

Tensor Gauss-Legendre of the given order on cells of a quadtree over each patch; all cells
of a level are evaluated in one field call (cells). A domain of fewer than MIN_INITIAL_CELLS
patches starts from the patches halved in both directions (those levels count as done). A
cell that meets no class boundary is accepted on its own Gauss sums when the difference to
the embedded lower-degree rule on the same nodes (gauss_rules.embedded_weights) fits
OWN_SAFETY of the budget; otherwise its four children are evaluated. Error estimate of a
parent cell: |Q(cell) - sum of Q over its 4 children| (coarse against fine resolution; it
estimates the coarse rule's error, so it is conservative for the children's sum, which is
what is kept). The tolerance of quantity q is tol_q = rtol max(|Q_q|, ZERO_SCALE s_q,
reference_q), s_q = A for areas and tau_K A for K integrals. A level whose accepted plus new
error estimates fit every tol_q ends the refinement. Otherwise the candidates are the cells
that fit, greedily (smallest errors first, using at most ACCEPT_FRACTION of the budget
left), TREE_SAFETY of the budget of the smooth quantities (areas; K integrals of cells
without a level curve): the quadtree is cheap, and this keeps their actual error far inside
rtol. The candidates' line integrals (lines) are then computed, and the candidates accepted
greedily again on every quantity against the whole budget left; the others are split. The
refinement ends at max_depth (the paper's protocol, with a recheck one level deeper) or,
driven by the error alone, at depth_limit levels or when the next level would exceed the
point budget. Every comparison with the point budget is recorded (budget_needed): a run the
budget never bound makes the same decisions, and gives the same result to the bit, under
every budget of at least the largest point count it compared within it.

A cell is mixed when its samples do not all have one class, or when the sampled range of K
(or of H where |K| may be below tau_K), widened by STRADDLE_MARGIN of itself, contains
-tau_K or tau_K (or -+tau_H), or K changes sign in it; the K integrals and class areas of a
parent cell with a mixed child are line integrals (lines).
"""
import math
import time
from dataclasses import replace

import numpy as np

from ...core.errors import InputError
from ...core.thresholds import check_positive, classify
from .cell_interpolant import grid_matrices_of_order
from .gauss_rules import gauss_rule
from .patches import Patches, check_domain
from .balance import unbalanced
from .cells import (CellSet, CountedField, mixed_cells, child_cells, greedy_accept, patch_cells, share_area_error, cell_nodes,
                    tensor_cells, values_at_nodes)
from .lines import integrate_lines, interpolants, turn_cells
from .pieces import LineSetting
from .result import QuadratureResult
from .settings import (ABS_K, AREA, K_INTEGRALS, LINE_K, LINE_Q, MAX_NONREGULAR, NQ, N_DEEPEST, N_PEAKS,
                       LINE_CHUNKS, LINE_MARGIN, N_SMOOTH, OWN_SAFETY,
                       QUANTITIES, TREE_SAFETY, ZERO_CHARGE_PARTS, ZERO_CHARGE_SHARE,
                       ZERO_SCALE)


class Integration:
    """State of one adaptive integration (quadtree over the patches, lines in mixed cells).

    Units of the result are accepted parent cells: their four children's Gauss sums give
    the values, or the lines for the LINE_Q quantities of mixed cells. Arguments as
    integrate's (point_budget: refine_to's, None for none); the first cells are evaluated
    here."""

    def __init__(self, domain, field, tau_H, tau_K, order, rtol, class_max_depth, u_breaks,
                 v_breaks, progress, patch_range=None, prefetch=None, max_depth=None, reference=None,
                 lines=True, point_budget=None, balance=False):
        self.prefetch = prefetch
        self.balance = bool(balance)  # the 2:1 balance on jumps (balance.unbalanced)
        self.f = CountedField(field)
        self.tau_H, self.tau_K = tau_H, tau_K
        self.order, self.rtol = order, rtol
        self.class_max_depth = class_max_depth
        self.lines = bool(lines)
        # zero_charge: the bounds charged for K = 0 in accepted cells (lines.line_values)
        self.zero_charge = 0.0
        self.progress = progress
        self.reference = np.array([abs(float((reference or {}).get(q, 0.0))) for q in QUANTITIES])
        self.x, self.w, self.w_embedded = gauss_rule(order)
        self.patches = Patches.of(domain, u_breaks, v_breaks) if prefetch is None else prefetch.patches
        # what the lines read; K = 0 cuts them only once the bounds charged instead would
        # not fit (_lines_of)
        self.ls = LineSetting(self.patches, self.f, tau_H, tau_K, class_max_depth,
                              *grid_matrices_of_order(order))
        self.active, level = patch_cells(self.patches, patch_range, max_depth)
        self.max_depth = max_depth if max_depth is not None else 0
        if prefetch is not None and (prefetch.order != order or not all(
                np.array_equal(getattr(prefetch.cells[0], k), getattr(self.active, k))
                for k in ("pid", "s0", "t0"))):
            raise InputError("the prefetched nodes are of another order, patch range or max_depth")
        P = self.active.size
        self.n_initial = P
        self.nonregular = []
        self.n_nonregular = 0
        self.accepted = []  # CellSets of accepted units, one per level
        self.err_acc = np.zeros(NQ)
        self.depth = level
        # the first split is of quadrants, with or without a prefetch of its children, and
        # with no balance: the same cells either way
        self.first_level = level
        self.pending = None  # units left unaccepted at the last level
        self.budget_spent = False  # refinement stopped by the point budget (refine_to)
        self.point_budget = None if point_budget is None else int(point_budget)
        # budget_needed: the smallest point budget under which every comparison with the
        # budget so far comes out as it did; budget_free: none of them was bound by it
        self.budget_needed, self.budget_free = 0, True
        self.field_lines = [0, 0]  # field points and units of the lines of the field so far
        self.active = self.evaluate(self.active, self._prefetched(0))
        if prefetch is not None:
            self.active = self.active.with_(row=np.arange(P))  # the first cell of each (_prefetched)
        self.history = []
        self._record_level()
        self.history *= level + 1  # the levels above the first cells': their estimate

    def _record_level(self):
        """Append the global estimate (accepted cells plus active cells' Gauss sums)."""
        Q = sum((p.Q.sum(0) for p in self.accepted), self.active.Q.sum(0))
        self.history.append({q: float(x) for q, x in zip(QUANTITIES, Q)})

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

    def evaluate(self, c, prefetched=None):
        """Tensor Gauss rule on the (sigma, t) cells c (CellSet), with the field's values at its
        nodes and the nodes when given (_prefetched; else computed).

        Returns the cells c with Q, mixed, peak, err_e, pmeas and the samples sJ, sK, sH,
        sreg (CellSet)."""
        x, w = self.x, self.w
        pid, s0, s1, t0, t1 = c.pid, c.s0, c.s1, c.t0, c.t1
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
        return c.with_(Q=Q, err_e=err_e, mixed=mixed_cells(cls, K, H, reg, self.tau_H, self.tau_K), peak=peak,
                       pmeas=W.sum((1, 2)), sJ=J, sK=K, sH=H, sreg=reg)

    def _tolerance(self, Q):
        """tol_q = rtol max(|Q_q|, ZERO_SCALE scale_q, reference_q) for all quantities, (9,)."""
        A = abs(Q[AREA])
        scale = np.full(NQ, A)
        scale[K_INTEGRALS] *= self.tau_K
        return self.rtol * np.maximum(np.maximum(np.abs(Q), ZERO_SCALE * scale), self.reference)

    def refine_to(self, depth_limit):
        """Refine level by level until converged, depth_limit is reached, or (point_budget
        given) the next level's children would take the field points evaluated beyond the
        point budget. Only the cells left unaccepted are refined, so the depth grows where
        the error estimates stay large (a singular corner costs four cells a level). Each
        level: cells accepted on their own Gauss sums, the others' children evaluated, the
        parents' candidates on the smooth quantities, the candidates' lines, and the
        candidates accepted on every quantity against the budget left."""
        per_cell = self.order * self.order
        point_budget = self.point_budget
        while self.active.size and self.depth < depth_limit:
            # the units left pending on the last level stand for the active cells (their
            # children): the children accepted on their own replace them only when the
            # refinement goes on, or all of them are
            before = (len(self.accepted), self.err_acc, self.active)
            self._accept_own()
            a = self.active
            na = a.size
            if na == 0:
                self.pending = None
                break
            pre = self._prefetched(1, a.row)
            reopen = self._unbalanced(a) if pre is None and self.depth > self.first_level else None
            nr = 0 if reopen is None else int(sum(r.sum() for r in reopen))
            # (a reopened unit: its four children now, their sixteen at the next level)
            if point_budget is not None and self.pending is not None \
                    and not self._within_budget(self.f.n_points + (4 * na + 20 * nr) * per_cell):
                del self.accepted[before[0]:]
                self.err_acc, self.active = before[1], before[2]
                self.budget_spent = True
                break
            if nr:
                a = self._reopened(a, reopen)
                na = a.size
            ch = self.evaluate(child_cells(a), pre)
            self.depth += 1
            # the last level: the depth limit, or the point budget would not hold the next
            # level's children (at most four a cell refined here)
            last = self.depth >= depth_limit or (
                point_budget is not None and not self._within_budget(self.f.n_points + 16 * na * per_cell))
            if last and self.depth < depth_limit:
                self.budget_spent = True
            unit, err = self._parent_units(a, ch)
            Qtot = sum((p.Q.sum(0) for p in self.accepted), unit.Q.sum(0))
            tol = self._tolerance(Qtot)
            budget = tol - self.err_acc
            accept, last, fit_trial = self._tree_candidates(unit, err, budget, last)
            lined, split, charge = self._line_candidates(a, ch, unit, err, accept, last, fit_trial, Qtot, tol)
            if fit_trial:  # every cell a candidate but those split for their interpolants
                accept = ~split
            self._accept_level(unit, err, accept, lined, charge, budget, last, ch)
            if self.progress is not None:
                self.progress(min(1.0, self.depth / float(depth_limit + 1) if point_budget is None
                                  else self.f.n_points / float(point_budget)),
                              "quadrature depth %d: %d of %d cells refined"
                              % (self.depth, int((~accept).sum()), na))

    def _unbalanced(self, a):
        """balance.unbalanced of the active cells a against the accepted units (None when
        the balance is off or finds none)."""
        if not self.balance or not self.accepted:
            return None
        Qtot = sum((p.Q.sum(0) for p in self.accepted), a.Q.sum(0))
        return unbalanced(self.patches, a, self.accepted, self._tolerance(Qtot)[ABS_K])

    def _reopened(self, a, reopen):
        """The active cells a joined by the children (evaluated here) of the accepted units
        reopen masks, those units and their errors taken out of the accepted ones."""
        gone = CellSet.concat([p.take(m) for p, m in zip(self.accepted, reopen)])
        self.accepted = [p.take(~m) for p, m in zip(self.accepted, reopen)]
        self.err_acc = self.err_acc - gone.err.sum(0)
        ch = self.evaluate(child_cells(gone.boxes()))
        names = ("Q", "err_e", "mixed", "peak", "pmeas", "sJ", "sK", "sH", "sreg")
        return CellSet.concat([a.boxes().with_(**{k: getattr(a, k) for k in names}),
                               ch.boxes().with_(**{k: getattr(ch, k) for k in names})])

    def _within_budget(self, points):
        """Whether points (the field points a step would reach) fit the point budget; the
        answer is recorded: the smallest budget that gives it (budget_needed), or that the
        budget bound the run (budget_free False)."""
        if points > self.point_budget:
            self.budget_free = False
            return False
        self.budget_needed = max(self.budget_needed, int(math.ceil(points)))
        return True

    def _parent_units(self, a, ch):
        """The active cells a as units (CellSet) of their children ch's Gauss sums, and their
        error estimates |Q(cell) - sum of Q over its children| (n, 9), the class areas'
        shared by class fraction (share_area_error)."""
        na = a.size
        pk = ch.peak.reshape(na, 4, 3)
        unit = a.boxes().with_(Q=ch.Q.reshape(na, 4, NQ).sum(1), mixed=ch.mixed.reshape(na, 4).any(1),
                               pmeas=ch.pmeas.reshape(na, 4).sum(1),
                               peak=pk[np.arange(na), pk[:, :, 2].argmax(1)], depth=np.full(na, self.depth))
        return unit, share_area_error(np.abs(a.Q - unit.Q), unit.Q)

    def _tree_candidates(self, unit, err, budget, last):
        """The units that fit, greedily, TREE_SAFETY of the budget of the smooth quantities
        (n,) bool, whether this level is the last, and whether it is tried as the last one:
        driven by the error (point_budget given), a level whose cells may fit the whole
        budget (the mixed cells' line quantities still to come) makes all its cells
        candidates, the mixed ones on lines (above max_depth, those whose interpolant is not
        yet accurate are split instead of taking lines of the field)."""
        mixed = unit.mixed
        err_tree = err.copy()
        if self.lines:
            err_tree[mixed, K_INTEGRALS] = 0.0  # K integrals of mixed cells: from the lines
        tree_budget = TREE_SAFETY * budget[:N_SMOOTH]
        if np.all(err_tree[:, :N_SMOOTH].sum(0) <= tree_budget):
            accept = np.ones(unit.size, bool)
        else:
            accept = greedy_accept(err_tree[:, :N_SMOOTH], tree_budget)
        fit_trial = False
        if self.point_budget is not None and not last and self.lines:
            hope = err.copy()
            hope[mixed, LINE_Q] = 0.0
            fit_trial = last = bool(np.all(hope.sum(0) <= budget))
        return accept, last, fit_trial

    def _line_candidates(self, a, ch, unit, err, accept, last, fit_trial, Qtot, tol):
        """Line integrals of the mixed candidate units (on the last level every mixed unit),
        written into unit.Q and err for LINE_Q; a mixed unit whose interpolant is not yet
        accurate is split instead (accept set False) unless this is the last level. Returns
        the units on lines (n,) bool, those split for their interpolants (n,) bool and the
        bounds charged on the lines for K = 0 (per lined unit)."""
        na = unit.size
        lined = unit.mixed & (accept | last) & self.lines
        split = np.zeros(na, bool)  # mixed cells split for their interpolants' sake
        charge = None
        if lined.any():
            P_tot = sum((p.pmeas.sum() for p in self.accepted), unit.pmeas.sum())
            sub = unit.take(lined)
            share = self._share(sub.Q, sub.pmeas, Qtot, P_tot)
            lbudget = 0.5 * share[:, LINE_Q] * tol[None, LINE_Q]
            interp = interpolants(self.ls, a, ch, lined, sub, lbudget)
            if (not last or (fit_trial and self.depth < self.max_depth)) and not interp.use.all():
                # a cell whose interpolant is not yet accurate is split rather than
                # integrated on lines of the field: its children's interpolants converge
                # fast, and four children cost less than the lines of one cell
                keep = interp.use
                split[np.nonzero(lined)[0][~keep]] = True
                accept[np.nonzero(lined)[0][~keep]] = False
                lined[lined] = keep
                sub = sub.take(keep)
                interp = interp.take(keep)
                lbudget = lbudget[keep]
        if lined.any() and last and self.point_budget is not None:
            return self._lines_within_budget(sub, interp, lbudget, tol, unit, err, lined, split)
        if lined.any():
            charge = self._lines_of(sub, interp, lbudget, err[lined], tol, unit, err, lined)
        return lined, split, charge

    def _lines_within_budget(self, sub, interp, lbudget, tol, unit, err, lined, split):
        """The lines of the last level under a point budget. Units on their interpolants take
        no field points: all in one pass. The units on lines of the field go largest error
        relative to tol first, in chunks sized by the points left at LINE_MARGIN times the
        points a unit's lines of the field cost (on this level once measured, before that on
        the face's earlier levels, and for a face's first ones, 1/LINE_CHUNKS^2 of them), each
        chunk at most as many units as are done (half of them from the earlier levels' cost
        alone), at most LINE_CHUNKS^2 of these chunks. The units not reached keep their Gauss
        sums and quadtree estimates (|Q(cell) - sum of Q over its children|) and stay pending.
        Returns the units on lines, those split and the bounds charged for K = 0, as
        _line_candidates."""
        idx = np.nonzero(lined)[0]
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.nan_to_num(err[idx][:, LINE_Q] / tol[None, LINE_Q], nan=0.0, posinf=1e300).sum(1)
        field = np.nonzero(~interp.use)[0]
        field = field[np.argsort(-rel[field], kind="stable")]
        charges = np.zeros(idx.size)
        err0 = err[idx].copy()
        done = np.zeros(idx.size, bool)

        def chunk(rows):
            """Lines of the units rows; returns the field points they took."""
            resolved, before, p0 = self.ls.resolve_zero, done.copy(), self.f.n_points
            charges[rows] = self._chunk_lines(rows, idx, sub, interp, lbudget, err0, tol, unit, err,
                                              float(charges[done].sum()))
            done[rows] = True
            points = self.f.n_points - p0
            if self.ls.resolve_zero and not resolved and before.any():
                # K = 0 resolved from this chunk on: the earlier chunks again, as in one pass
                again = np.nonzero(before)[0]
                charges[again] = self._chunk_lines(again, idx, sub, interp, lbudget, err0, tol, unit, err, 0.0)
            return points

        if interp.use.any():
            chunk(np.nonzero(interp.use)[0])
        n_field, spent = 0, 0
        for _ in range(LINE_CHUNKS * LINE_CHUNKS):
            if n_field == field.size:
                break
            n0 = self.f.n_points
            left = self.point_budget - n0
            cost = spent / n_field if n_field else self.field_line_cost()
            if cost is None:
                whole = min(max(1, field.size // LINE_CHUNKS ** 2), field.size - n_field)
                size, need = whole, n0 + 1
            else:  # a few units' cost says little of the rest's: at most double
                grow = n_field if n_field else field.size // 2
                whole = min(max(1, grow), field.size - n_field)
                per_unit = LINE_MARGIN * max(cost, 1.0)
                size = min(int(left / per_unit), whole)
                # from this many points on, the points left hold the whole chunk
                need = n0 + math.ceil(whole * per_unit * (1.0 + 1e-12)) + 1
            if left > 0 and size == whole:
                self._within_budget(need)
            else:  # the budget cut the chunk or ended the lines
                self.budget_free = False
            if left <= 0 or size < 1:
                break
            spent += chunk(field[n_field:n_field + size])
            n_field += size
        if not done.all():
            self.budget_spent = True
        lined = np.zeros(unit.size, bool)
        lined[idx[done]] = True
        return lined, split, charges[done]

    def _chunk_lines(self, rows, idx, sub, interp, lbudget, err0, tol, unit, err, earlier):
        """_lines_of the lined units rows (indices into sub, whose units are idx of unit) with
        their quadtree estimates err0; earlier: the bounds charged on this level before."""
        pick = np.zeros(idx.size, bool)
        pick[rows] = True
        mask = np.zeros(unit.size, bool)
        mask[idx[pick]] = True
        charge = self._lines_of(sub.take(pick), interp.take(pick), lbudget[pick], err0[pick], tol, unit, err,
                                mask, earlier=earlier)
        out = np.zeros(idx.size)
        out[pick] = charge
        return out[rows]

    def _lines_of(self, sub, interp, lbudget, err_lined, tol, unit, err, lined, earlier=0.0):
        """The lines of the units sub with their interpolants and budgets, into unit.Q and
        err at lined; K = 0 is resolved from here on when the bounds charged for it (with
        those charged earlier on this level) would take too much of the K integrals'
        tolerance. Returns the bounds charged (k,)."""
        mc = turn_cells(self.ls, sub, interp)
        p0 = self.f.n_points
        val, lerr, _, charge = integrate_lines(self.ls, mc, lbudget)
        if not self.ls.resolve_zero and np.any((self.zero_charge + earlier + charge.sum()) * ZERO_CHARGE_PARTS
                                               > ZERO_CHARGE_SHARE * tol[K_INTEGRALS]):
            # the bounds for K = 0 left unresolved would take too much of the K
            # integrals' tolerance (small K integrals): resolve it from here on
            self.ls = replace(self.ls, resolve_zero=True)
            val, lerr, _, charge = integrate_lines(self.ls, mc, lbudget)
        # the quadtree's children sums are an independent check of the K integrals:
        # a discrepancy beyond the line estimate that the quadtree also sees (its own
        # estimate) marks a rough or singular integrand the lines did not resolve.
        # Cells on an interpolant have passed a sharper check (the interpolant
        # against samples it was not built from), and there the discrepancy is the
        # Gauss sums' own error at the kink of |K| that the lines remove.
        kq = K_INTEGRALS
        gap = np.minimum(np.abs(val[:, LINE_K] - sub.Q[:, kq]), err_lined[:, kq])
        gap[interp.use] = 0.0
        lerr[:, LINE_K] = np.maximum(lerr[:, LINE_K], gap)
        unit.Q[lined, LINE_Q] = val
        err[lined, LINE_Q] = lerr
        self.field_lines[0] += self.f.n_points - p0
        self.field_lines[1] += int(np.count_nonzero(~interp.use))
        return charge

    def field_line_cost(self):
        """Field points a unit's lines of the field took on this face so far, None before any."""
        points, units = self.field_lines
        return points / units if units else None

    def _accept_level(self, unit, err, accept, lined, charge, budget, last, ch):
        """Accept the candidates again, greedily, on every quantity with the lines' errors
        against the budget left; the rest are refined (their children become active), or
        pending on the last level."""
        c = np.nonzero(accept)[0]
        if c.size and not np.all(err[c].sum(0) <= budget):
            accept[c] = greedy_accept(err[c], budget)
        unit = unit.with_(err=err)
        if accept.any():
            self.err_acc = self.err_acc + err[accept].sum(0)
            self.accepted.append(unit.take(accept))
            if lined.any():
                self.zero_charge += float(charge[accept[lined]].sum())
        self.pending = unit.take(~accept) if last else None
        self.active = ch.take(np.repeat(~accept, 4))
        self._record_level()

    def _accept_own(self):
        """Accept active cells on their own Gauss sums, without children: cells that meet
        no class boundary (not mixed), all samples regular, whose embedded error estimates
        err_e fit greedily in OWN_SAFETY of the remaining budget of every quantity (the
        class areas' errors: the area's, shared by class fraction, as for children sums)."""
        a = self.active
        n = a.size
        cand = ~a.mixed & a.sreg.reshape(n, -1).all(1) & np.isfinite(a.err_e).all(1)
        if not cand.any():
            return
        err = share_area_error(a.err_e.copy(), a.Q)
        Qtot = sum((p.Q.sum(0) for p in self.accepted), a.Q.sum(0))
        budget = OWN_SAFETY * (self._tolerance(Qtot) - self.err_acc)
        ok = np.zeros(n, bool)
        ok[cand] = greedy_accept(err[cand], budget)
        if not ok.any():
            return
        unit = a.boxes().take(ok).with_(Q=a.Q[ok], mixed=a.mixed[ok], pmeas=a.pmeas[ok], peak=a.peak[ok],
                                        depth=np.full(int(ok.sum()), self.depth), err=err[ok])
        self.err_acc = self.err_acc + unit.err.sum(0)
        self.accepted.append(unit)
        self.active = a.take(~ok)

    @staticmethod
    def _share(Q, pmeas, Qtot, P_tot):
        """Part (n, 9) of each quantity's tolerance that cells with integrals Q (n, 9) and
        parameter areas pmeas (n,) stand for: half by their quantity's share, half by the
        mean of their area and parameter-area shares."""
        with np.errstate(divide="ignore", invalid="ignore"):
            own = np.nan_to_num(np.abs(Q) / np.abs(Qtot)[None, :], nan=0.0, posinf=0.0)
        place = 0.5 * (np.maximum(Q[:, AREA], 0.0) / max(abs(Qtot[AREA]), 1e-300)
                       + pmeas / max(P_tot, 1e-300))
        return 0.5 * (np.minimum(own, 1.0) + place[:, None])

    def snapshot(self, max_depth, seconds_start):
        """Result of the current state: accepted units plus those left pending."""
        parts = list(self.accepted)
        if self.pending is not None and self.pending.size:
            parts.append(self.pending)
        units = CellSet.concat(parts)
        Q = units.Q.sum(0)
        err = units.err.sum(0)
        tol = self._tolerance(Q)
        pend = self.pending if self.pending is not None else units.take(slice(0, 0))
        unconv = self.patches.boxes(pend.pid, pend.s0, pend.s1, pend.t0, pend.t1)
        top = np.argsort(-units.peak[:, 2])[:N_PEAKS]
        deep = np.nonzero(units.depth == units.depth.max())[0][:N_DEEPEST]
        d = units.take(deep)
        deepest = self.patches.boxes(d.pid, d.s0, d.s1, d.t0, d.t1)
        nonreg = np.concatenate(self.nonregular) if self.nonregular else np.empty((0, 2))
        return QuadratureResult(
            values={q: float(x) for q, x in zip(QUANTITIES, Q)},
            errors={q: float(x) for q, x in zip(QUANTITIES, err)},
            tolerances={q: float(x) for q, x in zip(QUANTITIES, tol)},
            converged={q: bool(c) for q, c in zip(QUANTITIES, err <= tol)},
            order=self.order, rtol=self.rtol, max_depth=max_depth,
            depth_reached=int(units.depth.max()), n_points=self.f.n_points,
            n_field_calls=self.f.n_calls, n_cells=4 * int(units.size),
            n_initial_cells=self.n_initial, n_mixed_cells=int(units.mixed.sum()),
            nonregular_uv=nonreg, n_nonregular=self.n_nonregular, unconverged_cells=unconv,
            peak_KJ=units.peak[top], seconds=time.perf_counter() - seconds_start,
            history=list(self.history), zero_resolved=self.ls.resolve_zero,
            zero_charge=self.zero_charge, point_budget=self.point_budget, budget_spent=self.budget_spent,
            budget_needed=self.budget_needed if self.point_budget is not None and self.budget_free
            and not self.budget_spent else None, deepest_cells=deepest)


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
    check_domain("integrate", domain)
    tau_H = check_positive("tau_H", tau_H)
    tau_K = check_positive("tau_K", tau_K)
    check_positive("rtol", rtol)
    if int(order) < 1 or int(max_depth) < 1 or int(class_max_depth) < 0:
        raise InputError("quadrature order and max_depth must be >= 1 and class_max_depth "
                         ">= 0, got %r, %r, %r" % (order, max_depth, class_max_depth))
    start = time.perf_counter()
    it = Integration(domain, field, tau_H, tau_K, int(order), float(rtol), int(class_max_depth),
                     u_breaks, v_breaks, progress, patch_range, prefetch, int(max_depth), reference, lines,
                     point_budget if depth_limit is not None else None, balance=depth_limit is not None)
    if depth_limit is not None:
        it.refine_to(int(depth_limit))
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
