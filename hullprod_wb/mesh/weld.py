"""Exact grouping of equal rows (the weld of coincident vertices, paper section 4.2, and the
duplicate triangles of the quality record) by an open-addressing hash table built in
vectorised rounds.

Each row's bytes are read as 64-bit words (a 12-byte float32 row is one 64-bit and one
32-bit word), hashed to a slot of a table of at least twice as many slots as rows, and in
every round all pending rows write their index to their slot at once, in decreasing order,
so that the lowest index of a slot is kept. A row whose words equal those of its slot's
winner joins the winner's group; the other rows move on to their next slot (a probe step
that depends on the hash, so equal rows always travel together) in the next round. A
round settles at least one group per contested slot, and with the table at most half full
nearly all of them in the first. The winners are checked to be the lowest index of their
group; should that or the number of rounds fail, the rows are grouped by numpy's exact
(slower) sort instead. Equality is that of the stored bits, which is exact.
"""
import numpy as np

from ..core.threads import blocks, default_threads, run_blocks

#: Rounds of the hash table before the exact sort takes over.
MAX_ROUNDS = 64
#: Rows a block of the hash pass.
BLOCK = 1 << 16

_K = [np.uint64(c) for c in (0x9E3779B97F4A7C15, 0xC2B2AE3D27D4EB4F, 0x165667B19E3779F9,
                             0xBF58476D1CE4E5B9)]


def row_words(B):
    """The bytes of the rows of a contiguous (k, c) array of 32- or 64-bit values as a list of
    (k,) 64-bit (a last 32-bit one for an odd count of 32-bit values) unsigned-integer views."""
    nbytes = B.dtype.itemsize * B.shape[1]
    fields = [("w%d" % j, "<u8") for j in range(nbytes // 8)]
    if nbytes % 8:
        fields.append(("w%d" % len(fields), "<u4"))
    rec = B.view(np.dtype(fields)).reshape(len(B))
    return [rec[name] for name, _ in fields]


def row_hashes(words):
    """(k,) uint64 hash of the rows given as words (multiply, xor and shift finaliser)."""
    with np.errstate(over="ignore"):
        z = words[0] * _K[0]
        for j, w in enumerate(words[1:]):
            z ^= w * _K[1 + j % 3]
        z ^= z >> np.uint64(31)
        z *= _K[3]
        z ^= z >> np.uint64(29)
    return z


def hash_slots(words, bits):
    """(k,) intp slots of the rows given as words: the leading bits of their row_hashes,
    over blocks on default_threads() threads."""
    k = len(words[0])
    slot = np.empty(k, dtype=np.intp)
    shift = np.uint64(64 - bits)

    def block(sl):
        slot[sl] = row_hashes([w[sl] for w in words]) >> shift
    run_blocks(block, blocks(k, BLOCK), default_threads())
    return slot


def _exact_groups(B):
    """unique_rows by numpy's sort of the rows as opaque bytes."""
    rows_v = B.view(np.dtype((np.void, B.dtype.itemsize * B.shape[1]))).ravel()
    _, first, inv = np.unique(rows_v, return_index=True, return_inverse=True)
    by_first = np.argsort(first, kind="stable")
    rank = np.empty(len(first), dtype=np.int64)
    rank[by_first] = np.arange(len(first))
    return first[by_first], rank[inv.ravel()]


def _lowest_equal(words):
    """(k,) int: the lowest index of the row equal to each row, by the rounds of the module
    docstring; None when they do not settle (or the writes did not keep the lowest index)."""
    k = len(words[0])
    bits = max(4, int(2 * k - 1).bit_length())
    mask = (1 << bits) - 1
    slot = hash_slots(words, bits)
    itype = np.int32 if k < 2 ** 31 else np.int64
    table = np.empty(1 << bits, dtype=itype)
    ids = np.arange(k, dtype=itype)
    rep, step = None, None
    for _ in range(MAX_ROUNDS):
        table[slot[::-1]] = ids[::-1]
        cand, same, lowest = _winners(table, slot, ids, words, first_round=rep is None)
        if not lowest:                  # the writes did not keep the lowest index
            return None
        if rep is None:
            rep = cand
        else:
            rep[ids[same]] = cand[same]
        if same.all():
            return rep
        lost = ~same
        ids, slot = ids[lost], slot[lost]
        # odd step, from the other bits of the hash: visits every slot
        step = (row_hashes([w[ids] for w in words]) & np.uint64(mask)).astype(np.intp) | 1 \
            if step is None else step[lost]
        slot += step
        slot &= mask
    return None


def _winners(table, slot, ids, words, first_round):
    """(winner of each pending row's slot, (p,) bool: its words equal the winner's, whether
    every winner is at most its row's index) of one round, over blocks on
    default_threads() threads (the table is only read here). In the first round the
    pending rows are all rows, ids = 0..k-1."""
    p = len(ids)
    cand = np.empty(p, dtype=table.dtype)
    same = np.empty(p, dtype=bool)
    lowest = []

    def block(sl):
        c = table[slot[sl]]
        lowest.append(bool(np.all(c <= ids[sl])))
        eq = np.ones(len(c), dtype=bool)
        for w in words:
            eq &= w[c] == (w[sl] if first_round else w[ids[sl]])
        cand[sl], same[sl] = c, eq
    run_blocks(block, blocks(p, BLOCK), default_threads())
    return cand, same, all(lowest)


def unique_rows(B):
    """Exact unique rows of a (k, c) array of 32- or 64-bit values (module docstring).

    Returns (first (u,) index of each distinct row's first occurrence, increasing;
    inverse (k,) group of every row), groups numbered by first occurrence."""
    B = np.ascontiguousarray(B)
    k = len(B)
    if k == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    rep = _lowest_equal(row_words(B))
    if rep is None:
        return _exact_groups(B)
    first = np.flatnonzero(rep == np.arange(k, dtype=rep.dtype))
    if len(first) == k:
        return first, first
    rank = np.empty(k, dtype=np.int64)
    rank[first] = np.arange(len(first))
    return first, rank[rep]


def weld_exact(V, F=None):
    """Merge vertices with bit-identical coordinates (-0.0 equals 0.0), keeping the order of
    first occurrence. F None: V is a triangle soup, its (m, 3, 3) corners or 3m rows
    (triangle i = rows 3i..3i+2). Float32 vertices are compared as stored (their float64
    values are the same points). Returns (float64 vertices, faces, number merged)."""
    Vc = np.asarray(V)
    Vc = Vc + Vc.dtype.type(0.0) if Vc.dtype in (np.float32, np.float64) else Vc.astype(np.float64) + 0.0
    Vc = Vc.reshape(-1, 3)
    first, inverse = unique_rows(Vc)
    merged = len(Vc) - len(first)
    if F is None:
        faces = inverse.reshape(-1, 3)
    else:
        faces = inverse[F] if merged else F
    return (Vc[first] if merged else Vc).astype(np.float64, copy=False), faces, merged
