"""Benchmark of the mesh backend's hot path: curvature + signature on a generated mesh of
about 1,000,000 vertices (a closed R = 3, r = 1 torus by default), with I/O timed apart.

    /usr/bin/python3 bench/mesh_curvature.py [--n 577] [--repeat 3] [--threads N]
        [--mesh torus|wigley] [--io] [--analyze [FILE]]

Prints wall and CPU seconds (best and median of the repeats), the tracemalloc peak of one
curvature + signature pass and the process's peak resident memory. --io writes the mesh
as binary STL to a temporary folder and times reading it back (welding and preparation
included). --analyze times the whole command line `./hullprod analyze FILE` (default
../shared/hulls/mesh/wigley_full.stl) and assess_mesh on the same file. Prints figures
only; asserts nothing.
"""
import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
import tracemalloc

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

import numpy as np  # noqa: E402

from hullprod_wb.core.integrals import integrals_from_samples  # noqa: E402
from hullprod_wb.core.reference_length import resolve_reference_length  # noqa: E402
from hullprod_wb.core.signature import signature_values  # noqa: E402
from hullprod_wb.core.thresholds import Thresholds  # noqa: E402
from hullprod_wb.examples.analytic_meshes import half_wigley_mesh, torus_mesh  # noqa: E402
from hullprod_wb.mesh.curvature import default_threads, vertex_curvature  # noqa: E402


def curvature_and_signature(V, F, lref, threads):
    """The timed work: per-vertex curvature, valid domain, integrals and signature."""
    c = vertex_curvature(V, F, threads=threads)
    valid = ~c.boundary & ~c.nonmanifold & np.isfinite(c.K) & np.isfinite(c.H)
    rl = resolve_reference_length(V, c.vertex_area, explicit=lref)
    th = Thresholds(rl.value)
    ig = integrals_from_samples(c.K, c.H, c.vertex_area, valid, th.tau_H, th.tau_K)
    return signature_values(ig, rl.value)


def timed(fn, repeat):
    walls, cpus, out = [], [], None
    for _ in range(repeat):
        t, c = time.perf_counter(), time.process_time()
        out = fn()
        walls.append(time.perf_counter() - t)
        cpus.append(time.process_time() - c)
    return walls, cpus, out


def fmt(walls, cpus):
    return ("wall best %.3f s, median %.3f s; CPU best %.3f s, median %.3f s"
            % (min(walls), statistics.median(walls), min(cpus), statistics.median(cpus)))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mesh", choices=("torus", "wigley"), default="torus")
    ap.add_argument("--n", type=int, default=577, help="torus: quads around the tube (n x 3n grid); "
                    "wigley: quads along the draft (4n x n grid)")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--threads", type=int, default=None, help="block-pass threads (default %d)" % default_threads())
    ap.add_argument("--io", action="store_true", help="also time writing and reading a binary STL")
    ap.add_argument("--analyze", nargs="?", const=os.path.join(ROOT, "..", "shared", "hulls", "mesh", "wigley_full.stl"),
                    default=None, metavar="FILE", help="also time ./hullprod analyze FILE")
    args = ap.parse_args(argv)
    threads = args.threads or default_threads()

    t = time.perf_counter()
    if args.mesh == "torus":
        V, F = torus_mesh(args.n, pattern="random", seed=1)
        lref, ref = 8.0, 128.0 / (3.0 * np.pi)
    else:
        V, F = half_wigley_mesh(4 * args.n, args.n, pattern="random", seed=1)
        lref, ref = 1.0, 4.30990339
    gen = time.perf_counter() - t
    print("mesh: %s, %d vertices, %d triangles (generated in %.2f s)" % (args.mesh, len(V), len(F), gen))
    print("cores: %d, block-pass threads: %d, load average at start: %.2f (wall times grow when "
          "other processes share the cores; CPU times much less)" % (os.cpu_count() or 1, threads, os.getloadavg()[0]))

    walls, cpus, sig = timed(lambda: curvature_and_signature(V, F, lref, threads), args.repeat)
    print("curvature + signature (%d runs): %s" % (args.repeat, fmt(walls, cpus)))
    print("  I_D = %.6f (reference %.6f, rel. error %.2e), I_D+ = %.6f, I_D- = %.6f"
          % (sig["I_D"], ref, sig["I_D"] / ref - 1, sig["I_D_plus"], sig["I_D_minus"]))
    w1, c1, _ = timed(lambda: vertex_curvature(V, F, threads=threads), args.repeat)
    print("  of which vertex_curvature: %s" % fmt(w1, c1))

    tracemalloc.start()
    curvature_and_signature(V, F, lref, threads)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    mesh_bytes = V.nbytes + F.nbytes
    print("peak memory of one pass (tracemalloc): %.0f MB (mesh arrays themselves: %.0f MB)"
          % (peak / 2 ** 20, mesh_bytes / 2 ** 20))
    print("process peak resident memory so far (ru_maxrss): %.0f MB"
          % (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0))

    if args.io:
        import trimesh
        from hullprod_wb.mesh.loading import load_mesh
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "bench.stl")
            t = time.perf_counter()
            trimesh.Trimesh(V, F, process=False).export(path, file_type="stl")
            tw = time.perf_counter() - t
            t = time.perf_counter()
            m = load_mesh(path)
            tr = time.perf_counter() - t
            print("I/O: wrote %.0f MB binary STL in %.2f s; load_mesh (read, weld, checks, orientation) %.2f s, "
                  "%d vertices" % (os.path.getsize(path) / 2 ** 20, tw, tr, len(m.vertices)))
        print("process peak resident memory after I/O (ru_maxrss): %.0f MB"
              % (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0))

    if args.analyze:
        path = os.path.abspath(args.analyze)
        if not os.path.isfile(path):
            print("analyze: %s not present, skipped" % path)
            return 0
        launcher = os.path.join(ROOT, "hullprod")
        if os.path.isfile(launcher):
            runs = []
            for _ in range(args.repeat):
                t = time.perf_counter()
                proc = subprocess.run([launcher, "analyze", path, "--quiet"], capture_output=True, text=True)
                runs.append(time.perf_counter() - t)
            print("./hullprod analyze %s: exit %d, wall best %.2f s, median %.2f s (interpreter start and "
                  "imports included)" % (os.path.relpath(path, ROOT), proc.returncode, min(runs), statistics.median(runs)))
        from hullprod_wb.mesh.backend import assess_mesh
        r = assess_mesh(path)
        print("assess_mesh in-process: " + ", ".join("%s %.3f s" % (k, v) for k, v in r.timings.items()))
        print("  I_D = %s (%s)" % (r.validity["I_D"].value, r.validity["I_D"].status.value))
    return 0


if __name__ == "__main__":
    sys.exit(main())
