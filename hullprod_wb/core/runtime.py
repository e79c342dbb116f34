"""The runtime settings of HullProd's processes: one table (SETTINGS), read by the launcher
(./hullprod exports them; tests/test_launcher.py checks its lines against shell_exports()),
the GUI's assessment process (app.assessment_process), batch workers (batch.runner) and the
reading processes the Python API starts as fresh interpreters (brep.reading.reader_process).

Each setting is an environment variable that a library reads once, when a process starts
(glibc's allocator, OpenBLAS, OpenMP, numpy), so it acts on processes started with it, never
on the process that sets it. A value the caller has set is kept. What each setting saves is
measured in docs/benchmarks.md.

    python3 -m hullprod_wb.core.runtime     prints the launcher's export lines
"""
import os
from dataclasses import dataclass


@dataclass(frozen=True)
class Setting:
    """One environment variable: its name, the value HullProd's processes start with, and
    what it does."""

    name: str
    value: str
    does: str


SETTINGS = (
    Setting("OPENBLAS_NUM_THREADS", "1",
            "OpenBLAS works on the calling thread (many small products; processes run in parallel)"),
    Setting("OMP_NUM_THREADS", "1", "OpenMP code runs on the calling thread, for the same reason"),
    Setting("MALLOC_MMAP_THRESHOLD_", "33554432",
            "glibc serves allocations up to 32 MiB from the heap instead of mapping fresh pages"),
    Setting("MALLOC_TRIM_THRESHOLD_", "1099511627776",
            "glibc keeps freed heap memory for reuse (up to 1 TiB) instead of returning it to the kernel"),
    Setting("MALLOC_TOP_PAD_", "67108864", "glibc grows the heap by 64 MiB at a time"),
    Setting("MALLOC_ARENA_MAX", "1", "one heap for all threads: memory one thread frees, the others reuse"),
    Setting("MALLOC_MMAP_MAX_", "0",
            "no allocation gets a mapping of its own: large arrays come from the heap too"),
    Setting("NUMPY_MADVISE_HUGEPAGE", "0", "numpy does not ask the kernel for 2 MiB pages behind large arrays"),
)

#: What batch workers are started with on top of SETTINGS, replacing the caller's values: one
#: thread for every linear-algebra library (the thread count changes the order of numpy's
#: reductions, so equal settings make local and Dask results bit-identical) and one face
#: process per case (HULLPROD_JOBS, core.processes.JOBS_ENV: each worker runs one case).
BATCH_WORKER = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
                "HULLPROD_JOBS": "1"}


def environment(base=None):
    """base (default os.environ) as a new dict with every setting base does not set."""
    env = dict(os.environ if base is None else base)
    for s in SETTINGS:
        env.setdefault(s.name, s.value)
    return env


def shell_exports():
    """The launcher's export lines: each setting with its comment, a value the caller set kept."""
    lines = []
    for s in SETTINGS:
        lines.append("# %s" % s.does)
        lines.append('export %s="${%s:-%s}"' % (s.name, s.name, s.value))
    return lines


if __name__ == "__main__":
    print("\n".join(shell_exports()))
