"""Memory an assessment of a mesh file will need, estimated from the file's header before it
is read, and the refusal of files that would not fit.

The estimate is linear in the counts the header gives (readers.header_counts):
peak = BYTES_PER_VERTEX n + BYTES_PER_FACE m + FILE_COPIES times the file's size (what the
reader holds while it parses) + a fixed BASE for the interpreter and its libraries. The
coefficients are the measured peak resident memory of the whole command
(docs/benchmarks.md) with a margin of about 40 %.
"""
import os

from ..core.errors import InputError
from .readers import header_counts

#: Peak bytes per vertex and per triangle of the whole command, with a margin.
BYTES_PER_VERTEX = 150
BYTES_PER_FACE = 280
#: Interpreter, numpy, scipy: bytes.
BASE = 150 * 2 ** 20
#: Copies of the file the reader holds while it parses: the records (STL, PLY), the
#: text and its keyword-free copy (OBJ).
FILE_COPIES = {"stl": 1, "ply": 1, "obj": 2}
#: Environment variable overriding the memory taken as available (bytes), e.g. for a
#: process limited below the machine's memory.
AVAILABLE_ENV = "HULLPROD_MEMORY_BYTES"


def estimated_bytes(path, fmt):
    """(bytes, vertices, faces): the estimated peak memory of assessing the file."""
    n, m = header_counts(path, fmt)
    size = os.path.getsize(path)
    need = BASE + BYTES_PER_VERTEX * n + BYTES_PER_FACE * m + FILE_COPIES.get(fmt, 1) * size
    return need, n, m


def available_bytes():
    """Memory available to this process: $HULLPROD_MEMORY_BYTES, else MemAvailable of
    /proc/meminfo, else the physical memory (None if unknown)."""
    env = os.environ.get(AVAILABLE_ENV)
    if env:
        try:
            return int(float(env))
        except ValueError:
            raise InputError("%s must be a number of bytes, got %r" % (AVAILABLE_ENV, env)) from None
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return None


def check_memory(path, fmt):
    """InputError naming the memory needed when the file would not fit (module docstring)."""
    need, n, m = estimated_bytes(path, fmt)
    have = available_bytes()
    if have is not None and need > have:
        raise InputError("mesh file %s: about %d vertices and %d triangles need about %.1f GB of "
                         "memory and %.1f GB are available; split the mesh or use a machine with "
                         "more memory" % (path, n, m, need / 1e9, have / 1e9))
    return need
