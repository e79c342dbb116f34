"""Threads for array passes (the mesh path's, the reference length's moments): numpy's array
loops and scipy's sparse constructions release the GIL, so passes over disjoint parts of
the arrays run side by side on the cores (MAX_THREADS at most)."""
from concurrent.futures import ThreadPoolExecutor

from .processes import available_cpus

#: Threads of a block pass at most: the passes are bound by memory bandwidth beyond two.
MAX_THREADS = 2


def default_threads():
    """Worker threads for the block passes: up to MAX_THREADS, never more than the CPUs
    available (processes.available_cpus)."""
    return max(1, min(MAX_THREADS, available_cpus()))


def blocks(m, size):
    """Slices of size items (the last shorter) covering range(m)."""
    return [slice(a, min(a + size, m)) for a in range(0, m, size)]


def run_blocks(fn, blocks, threads):
    """Apply fn to every block; blocks write disjoint slices, so threads may share them."""
    if threads > 1 and len(blocks) > 1:
        with ThreadPoolExecutor(max_workers=threads) as pool:
            list(pool.map(fn, blocks))
    else:
        for sl in blocks:
            fn(sl)


def iter_parts(fns, threads):
    """fn() for fn in fns, in order, as an iterator: the calls run on up to threads
    threads, and a result is let go of once the caller has taken it."""
    if threads > 1 and len(fns) > 1:
        with ThreadPoolExecutor(max_workers=threads) as pool:
            yield from pool.map(lambda fn: fn(), fns)
    else:
        for fn in fns:
            yield fn()
