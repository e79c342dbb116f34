"""The paper's reference package (hullprod 1.0.1 from PyPI) in a virtual environment of
its own, for the benchmarks that run it side by side (run it with a fresh
HULLPROD_CACHE_DIR each time: it caches results by file hash)."""
import os
import subprocess
import sys

REFERENCE = "hullprod==1.0.1"


def ensure_reference_venv(venv):
    """The reference's `hullprod` executable in venv, created and installed there when absent."""
    exe = os.path.join(venv, "bin", "hullprod")
    if not os.path.exists(exe):
        subprocess.run([sys.executable, "-m", "venv", venv], check=True)
        subprocess.run([os.path.join(venv, "bin", "pip"), "install", "-q", REFERENCE], check=True)
    return exe
