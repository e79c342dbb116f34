"""The 2:1 balance on jumps: accepted units that missed a layer along their edge.

A quadtree accepts a unit when its Gauss sums agree with its children's. A layer narrower
than the unit's node spacing that runs along (and just inside) one of its edges can be
missed by every node of both, while the cells across that edge, refined much deeper, sample
it. |K| J is continuous across a cell edge, so when the samples of a cell next to the edge
it shares with a unit at least four times its size exceed BALANCE_JUMP times the largest
|K| J the unit sampled, the unit has not seen what reaches into it, and it is refined again.
Only cells whose |K| integral is at least BALANCE_SHARE of its tolerance are compared:
jumps that cannot matter to the result do not reopen anything.
"""
import numpy as np

from .cells import CellSet
from .settings import ABS_K, BALANCE_JUMP, BALANCE_SHARE

#: A unit is "much larger" than a cell when its side is this many times the cell's or more.
SIZE_RATIO = 4.0


def _edge_keys(pid, x):
    """Integer keys of (patch, edge coordinate) pairs; dyadic coordinates are exact."""
    return pid.astype(np.int64) * (1 << 46) + np.round(np.asarray(x) * float(1 << 44)).astype(np.int64)


def facing_units(c_pid, c_edge, c_lo, c_hi, u_pid, u_edge, u_lo, u_hi):
    """For each cell edge (patch c_pid, at c_edge, spanning [c_lo, c_hi] along it), the index
    of the unit whose edge (u_pid, u_edge, [u_lo, u_hi]) lies on the same line and contains
    that span, else -1 (the units' spans on one line are disjoint)."""
    kc, ku = _edge_keys(c_pid, c_edge), _edge_keys(u_pid, u_edge)
    _, inv = np.unique(np.concatenate((kc, ku)), return_inverse=True)
    gc, gu = inv[:kc.size], inv[kc.size:]
    key_u = gu * 4.0 + u_lo
    order = np.argsort(key_u, kind="stable")
    j = np.searchsorted(key_u[order], gc * 4.0 + c_lo + 1e-12, side="right") - 1
    jj = order[np.maximum(j, 0)]
    ok = (j >= 0) & (gu[jj] == gc) & (u_lo[jj] <= c_lo + 1e-12) & (u_hi[jj] >= c_hi - 1e-12)
    return np.where(ok, jj, -1)


def _side(c):
    return np.maximum(c.s1 - c.s0, c.t1 - c.t0)


def unbalanced(cells, accepted, tol_abs_k):
    """Per part of accepted (a list of CellSets of accepted units), a (k,) bool mask of the
    units to refine again beside the evaluated cells (CellSet with sK, sJ, sreg, Q and its
    |K| integral in column ABS_K of Q), with tol_abs_k the |K| integral's tolerance; None when
    there are none."""
    if cells.size == 0 or not accepted:
        return None
    units = CellSet.concat(accepted)
    big = np.nonzero(_side(units) > SIZE_RATIO * (1 - 1e-9) * _side(cells).min())[0]
    if big.size == 0:
        return None
    seen = cells.Q[:, ABS_K] >= BALANCE_SHARE * tol_abs_k
    if not seen.any():
        return None
    c = cells.take(seen)
    KJ = np.where(c.sreg, np.abs(c.sK) * c.sJ, 0.0)
    u = units.take(big)
    hit = np.zeros(big.size, bool)
    # each edge of a cell against the units across it: (the cell's edge, its samples
    # there, the unit's facing edge, the intervals along the edge)
    for c_edge, row, u_edge, c_lo, c_hi, u_lo, u_hi in (
            (c.t1, KJ[:, :, -1], u.t0, c.s0, c.s1, u.s0, u.s1),
            (c.t0, KJ[:, :, 0], u.t1, c.s0, c.s1, u.s0, u.s1),
            (c.s1, KJ[:, -1, :], u.s0, c.t0, c.t1, u.t0, u.t1),
            (c.s0, KJ[:, 0, :], u.s1, c.t0, c.t1, u.t0, u.t1)):
        j = facing_units(c.pid, c_edge, c_lo, c_hi, u.pid, u_edge, u_lo, u_hi)
        k = j >= 0
        small = _side(c)[k] * SIZE_RATIO * (1 - 1e-9) <= _side(u)[j[k]]
        jump = row.max(1)[k] > BALANCE_JUMP * np.maximum(u.peak[j[k], 2], 0.0)
        hit[j[k][small & jump]] = True
    if not hit.any():
        return None
    mask = np.zeros(units.size, bool)
    mask[big[hit]] = True
    out, start = [], 0
    for p in accepted:
        out.append(mask[start:start + p.size])
        start += p.size
    return out
