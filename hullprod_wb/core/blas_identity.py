"""Which BLAS numpy's matrix products run on, and with how many threads.

A blocked BLAS kernel splits a product's sums by its block sizes and threads, and it picks the
kernel for the CPU it runs on, so the last bits of a product depend on the library, its kernel
and its thread count. A stored result is the one a fresh integration gives only when these
match (brep.face_keys.settings_digest takes blas_identity()).

The library is the one that defines the cblas_dgemm numpy's extension links (dladdr), not
whatever BLAS libraries happen to be loaded (scipy may bring others, depending on what was
imported first); an OpenBLAS tells its build and threads through its own entry points.
"""
import ctypes
import os

#: numpy's double product under the names its builds link (plain, 64-bit interface, the
#: SciPy-built wheels').
DGEMM_SYMBOLS = ("cblas_dgemm", "cblas_dgemm64_", "scipy_cblas_dgemm64_", "scipy_cblas_dgemm")
#: OpenBLAS's entry points under the same builds' names: (build string, threads).
OPENBLAS_SYMBOLS = (("openblas_get_config", "openblas_get_num_threads"),
                    ("openblas_get_config64_", "openblas_get_num_threads64_"),
                    ("scipy_openblas_get_config64_", "scipy_openblas_get_num_threads64_"))

_FOUND = None  # (library file, OpenBLAS build or None, its threads function or None); () if none


class _DlInfo(ctypes.Structure):
    _fields_ = [("dli_fname", ctypes.c_char_p), ("dli_fbase", ctypes.c_void_p),
                ("dli_sname", ctypes.c_char_p), ("dli_saddr", ctypes.c_void_p)]


def numpy_blas_file():
    """The file of the library whose cblas_dgemm numpy's extension calls, resolved; None
    where that cannot be told (no dladdr, a numpy without a BLAS of its own)."""
    try:
        try:
            from numpy._core import _multiarray_umath as umath
        except ImportError:
            from numpy.core import _multiarray_umath as umath
        extension, libc = ctypes.CDLL(umath.__file__), ctypes.CDLL(None)
        for name in DGEMM_SYMBOLS:
            dgemm = getattr(extension, name, None)
            if dgemm is None:
                continue
            info = _DlInfo()
            if libc.dladdr(ctypes.cast(dgemm, ctypes.c_void_p), ctypes.byref(info)) and info.dli_fname:
                return os.path.realpath(info.dli_fname.decode())
    except (OSError, AttributeError, ImportError):
        return None
    return None


def _found():
    global _FOUND
    if _FOUND is None:
        path = numpy_blas_file()
        _FOUND = ()
        if path is not None:
            _FOUND = (path, None, None)
            try:
                lib = ctypes.CDLL(path)
            except OSError:
                return _FOUND
            for config_name, threads_name in OPENBLAS_SYMBOLS:
                config, threads = getattr(lib, config_name, None), getattr(lib, threads_name, None)
                if config is not None and threads is not None:
                    config.restype, threads.restype = ctypes.c_char_p, ctypes.c_int
                    _FOUND = (path, config().decode("ascii", "replace"), threads)
                    break
    return _FOUND


def blas_identity():
    """[library, build, threads] of numpy's BLAS: ['openblas', its build string (which names
    the kernel chosen for this CPU), its current threads] for an OpenBLAS; ['library', its
    file, None] for another (a reference BLAS runs on the calling thread); ['unknown', '',
    None] where it cannot be told. The threads are read at each call (a pool may be resized
    while a process runs)."""
    found = _found()
    if not found:
        return ["unknown", "", None]
    path, config, threads = found
    if config is None:
        return ["library", path, None]
    return ["openblas", config, int(threads())]
