"""Which BLAS numpy's matrix products run on, and with how many threads.

A blocked BLAS kernel splits a product's sums by its block sizes and threads, and it picks the
kernel for the CPU it runs on, so the last bits of a product depend on the library, its kernel
and its thread count. A stored result is the one a fresh integration gives only when these
match (brep.face_keys.settings_digest takes blas_identity()).

threadpoolctl tells it where it is installed; otherwise the BLAS libraries mapped into this
process (Linux: /proc/self/maps) are asked through their OpenBLAS entry points, and a library
without them (a reference BLAS, on the calling thread) is named by its file.
"""
import ctypes
import os

#: OpenBLAS's entry points under the symbol names its builds use (plain, 64-bit interface,
#: the SciPy-built wheels'): (config, threads).
OPENBLAS_SYMBOLS = (("openblas_get_config", "openblas_get_num_threads"),
                    ("openblas_get_config64_", "openblas_get_num_threads64_"),
                    ("scipy_openblas_get_config64_", "scipy_openblas_get_num_threads64_"))

_FOUND = None  # (config bytes, threads function) once looked up, () when none was found


def _mapped_blas_libraries():
    """Paths of the shared libraries mapped into this process whose name mentions BLAS
    (empty where /proc/self/maps cannot be read)."""
    try:
        with open("/proc/self/maps") as fh:
            paths = {line.split()[-1] for line in fh if "blas" in line.lower()}
    except OSError:
        return []
    return sorted(p for p in paths if p.startswith("/"))


def _openblas():
    """(config, threads function) of the OpenBLAS mapped into this process, or ()."""
    global _FOUND
    if _FOUND is None:
        import numpy  # noqa: F401  (loads numpy's BLAS, if it is not loaded yet)
        _FOUND = ()
        for path in _mapped_blas_libraries():
            try:
                lib = ctypes.CDLL(path)
            except OSError:
                continue
            for config_name, threads_name in OPENBLAS_SYMBOLS:
                config, threads = getattr(lib, config_name, None), getattr(lib, threads_name, None)
                if config is not None and threads is not None:
                    config.restype = ctypes.c_char_p
                    threads.restype = ctypes.c_int
                    _FOUND = (config(), threads)
                    break
            if _FOUND:
                break
    return _FOUND


def _from_threadpoolctl():
    """[[internal_api, version and architecture, threads], ...] of numpy's BLAS pools by
    threadpoolctl, or None when it is not installed."""
    try:
        from threadpoolctl import threadpool_info
    except ImportError:
        return None
    import numpy  # noqa: F401
    pools = [p for p in threadpool_info() if p.get("user_api") == "blas"]
    return sorted([str(p.get("internal_api")), "%s %s" % (p.get("version"), p.get("architecture")),
                   int(p.get("num_threads", 0))] for p in pools)


def blas_identity():
    """What sets the last bits of numpy's products in this process, a list of
    [library, build, threads]: by threadpoolctl; else the OpenBLAS mapped here (its build
    string names the kernel chosen for this CPU) with its current threads; else each BLAS
    library mapped here by its file, threads None (a reference BLAS runs on the calling
    thread); [['unknown', '', None]] where none is seen. The thread count is read at each
    call (a pool may be resized while a process runs)."""
    pools = _from_threadpoolctl()
    if pools:
        return pools
    found = _openblas()
    if found:
        config, threads = found
        return [["openblas", config.decode("ascii", "replace"), int(threads())]]
    files = sorted({os.path.realpath(p) for p in _mapped_blas_libraries()})
    return [["library", f, None] for f in files] or [["unknown", "", None]]
