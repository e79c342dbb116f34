"""The 2:1 balance on jumps: accepted units that missed a layer along their edge.

A quadtree accepts a unit when its Gauss sums agree with its children's. A layer narrower
than the unit's node spacing that runs along (and just inside) one of its edges can be
missed by every node of both, while the cells across that edge, refined much deeper, sample
it. |K| J is continuous across a cell edge, so when the samples of a cell next to the edge
it shares with a unit at least four times its size exceed BALANCE_JUMP times the largest
|K| J the unit sampled, the unit has not seen what reaches into it, and it is refined again.
Only cells whose |K| integral is at least BALANCE_SHARE of its tolerance are compared:
jumps that cannot matter to the result do not reopen anything. Cells and units are compared
within a patch and across the sides patches share (a knot line, a slab's end): a B-spline is
C2 across a simple knot, so K is continuous there too; across a multiple knot, where K may
jump, the balance can only refine more than needed.
"""
import numpy as np

from .cells import CellSet
from .settings import ABS_K, BALANCE_JUMP, BALANCE_SHARE

#: A unit is "much larger" than a cell when its side is this many times the cell's or more.
SIZE_RATIO = 4.0


def _edge_lines(patches, c, side):
    """The line each cell of c has on its side ("t0", "t1", "s0" or "s1") and the interval
    it spans along it, in coordinates two patches share: keys (n, 3) float (equal for the
    same line), lo, hi (n,). Inside a patch a side is the line sigma or t = const of that
    patch (spanned in the other coordinate). A side on the patch's boundary t = 0 (1) is its
    lower (upper) bound, a piece of the domain or a constant v, in its slab (the patches of
    a slab share sigma), spanned in sigma; a side on sigma = 0 (1) is the line u = u0 (u1),
    spanned in v (scaled to the domain's v range), shared by the patches on both sides."""
    pid = c.pid
    n = pid.size
    keys = np.zeros((n, 3))
    if side in ("t0", "t1"):
        t = c.t0 if side == "t0" else c.t1
        piece = patches.lo_piece if side == "t0" else patches.hi_piece
        const = patches.lo_v if side == "t0" else patches.hi_v
        lo, hi = c.s0.copy(), c.s1.copy()
        keys[:, 1], keys[:, 2] = pid, t
        edge = t == (0.0 if side == "t0" else 1.0)
        p = piece[pid[edge]]
        keys[edge, 0] = np.where(p >= 0, 1.0, 2.0)
        keys[edge, 1] = patches.u0[pid[edge]]
        keys[edge, 2] = np.where(p >= 0, p, const[pid[edge]])
        return keys, lo, hi
    sig = c.s0 if side == "s0" else c.s1
    lo, hi = c.t0.copy(), c.t1.copy()
    keys[:, 0], keys[:, 1], keys[:, 2] = 3.0, pid, sig
    edge = np.nonzero(sig == (0.0 if side == "s0" else 1.0))[0]
    if edge.size:
        q = pid[edge]
        u = patches.u0[q] if side == "s0" else patches.u1[q]
        blo, bhi = patches.bounds(q, u)
        v0, w = patches.domain.v_range[0], max(patches.domain.v_range[1] - patches.domain.v_range[0], 1e-300)
        keys[edge, 0], keys[edge, 1], keys[edge, 2] = 4.0, u, 0.0
        lo[edge] = (blo + c.t0[edge] * (bhi - blo) - v0) / w
        hi[edge] = (blo + c.t1[edge] * (bhi - blo) - v0) / w
    return keys, lo, hi


def facing_units(c_key, c_lo, c_hi, u_key, u_lo, u_hi):
    """For each cell side (its line's key (n, 3) and span [c_lo, c_hi] along it, _edge_lines),
    the index of the unit side on the same line whose span contains it, else -1 (the units'
    spans on one line are disjoint)."""
    keys = np.concatenate((c_key, u_key))
    code = np.zeros(keys.shape[0], np.int64)
    for col in keys.T:  # each column's values numbered, the numbers combined into one
        _, num = np.unique(col, return_inverse=True)
        code = code * (int(num.max()) + 1) + num.ravel()
    _, inv = np.unique(code, return_inverse=True)
    inv = inv.ravel()
    gc, gu = inv[:c_key.shape[0]], inv[c_key.shape[0]:]
    key_u = gu * 4.0 + u_lo
    order = np.argsort(key_u, kind="stable")
    j = np.searchsorted(key_u[order], gc * 4.0 + c_lo + 1e-12, side="right") - 1
    jj = order[np.maximum(j, 0)]
    ok = (j >= 0) & (gu[jj] == gc) & (u_lo[jj] <= c_lo + 1e-12) & (u_hi[jj] >= c_hi - 1e-12)
    return np.where(ok, jj, -1)


def _size(c):
    """A cell's side in its patch's coordinates."""
    return np.maximum(c.s1 - c.s0, c.t1 - c.t0)


def _size_uv(patches, c):
    """A cell's side in (u, v) (its v extent at its mid-line in sigma): for cells of two
    patches, whose coordinates differ in scale."""
    u, _ = patches.u_of_sigma(np.stack((c.pid, c.pid), 1), np.stack((c.s0, c.s1), 1))
    um = 0.5 * (u[:, 0] + u[:, 1])
    lo, hi = patches.bounds(c.pid, um)
    return np.maximum(np.abs(u[:, 1] - u[:, 0]), (c.t1 - c.t0) * np.abs(hi - lo))


def unbalanced(patches, cells, accepted, tol_abs_k):
    """Per part of accepted (a list of CellSets of accepted units), a (k,) bool mask of the
    units to refine again beside the evaluated cells (CellSet with sK, sJ, sreg, Q and its
    |K| integral in column ABS_K of Q) of the Patches patches, in the same patch or across a
    patch's side, with tol_abs_k the |K| integral's tolerance; None when there are none."""
    if cells.size == 0 or not accepted:
        return None
    seen = cells.Q[:, ABS_K] >= BALANCE_SHARE * tol_abs_k
    if not seen.any():
        return None
    c = cells.take(seen)
    units = CellSet.concat(accepted)
    # the units that may be much larger than a cell: in their patch's coordinates, or any
    # on a patch's side (across it the coordinates differ in scale)
    cand = np.nonzero((_size(units) > SIZE_RATIO * (1 - 1e-9) * _size(c).min())
                      | (units.t0 == 0.0) | (units.t1 == 1.0) | (units.s0 == 0.0) | (units.s1 == 1.0))[0]
    if cand.size == 0:
        return None
    u = units.take(cand)
    KJ = np.where(c.sreg, np.abs(c.sK) * c.sJ, 0.0)
    hit = np.zeros(u.size, bool)
    # each side of a cell against the units across it: (the cell's side, its samples
    # there, the unit's facing side)
    for c_side, row, u_side in (("t1", KJ[:, :, -1], "t0"), ("t0", KJ[:, :, 0], "t1"),
                                ("s1", KJ[:, -1, :], "s0"), ("s0", KJ[:, 0, :], "s1")):
        j = facing_units(*_edge_lines(patches, c, c_side), *_edge_lines(patches, u, u_side))
        k = np.nonzero(j >= 0)[0]
        if k.size == 0:
            continue
        jk = j[k]
        jump = row.max(1)[k] > BALANCE_JUMP * np.maximum(u.peak[jk, 2], 0.0)
        k, jk = k[jump], jk[jump]
        if k.size == 0:
            continue
        # much smaller: in the patch's coordinates within a patch, in (u, v) across patches
        small = _size(c)[k] * SIZE_RATIO * (1 - 1e-9) <= _size(u)[jk]
        other = np.nonzero(c.pid[k] != u.pid[jk])[0]
        if other.size:
            small[other] = _size_uv(patches, c.take(k[other])) * SIZE_RATIO <= _size_uv(patches, u.take(jk[other]))
        hit[jk[small]] = True
    if not hit.any():
        return None
    mask = np.zeros(units.size, bool)
    mask[cand[hit]] = True
    out, start = [], 0
    for p in accepted:
        out.append(mask[start:start + p.size])
        start += p.size
    return out
