"""Batch throughput: cases per minute against the number of local worker processes.

Generates a half-Wigley family (B/L and T/L varied, exact Bezier patches as STEP files,
optionally also triangle meshes as STL) in a temporary folder and assesses it with 1, 2, ...
local workers (and optionally on a Dask LocalCluster), printing one table row per setting.
No assertions: a measurement (on a shared machine, --repeat reports the fastest of N runs).

    /usr/bin/python3 bench/batch.py [--cases 12] [--workers 1 2] [--mesh] [--dask] [--repeat 1]
                                    [--option rtol=1e-2 --option display_deflection=0.01 ...]
"""
import argparse
import os
import sys
import tempfile
import time

# cold runs: every face integrated, none taken from a store of faces (core.result_store)
os.environ["HULLPROD_FACE_CACHE"] = "off"

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def write_family(folder, n, mesh=False):
    """n half-Wigley hulls, B/L in [0.05, 0.14] and T/L in {0.05, 0.0625, 0.08}."""
    import numpy as np
    from hullprod_wb.examples.builtin import half_wigley_shape
    Bs = np.linspace(0.05, 0.14, max(1, (n + 2) // 3))
    Ts = (0.05, 0.0625, 0.08)
    params = [(B, T) for B in Bs for T in Ts][:n]
    for k, (B, T) in enumerate(params):
        if mesh:
            from hullprod_wb.examples.analytic_meshes import half_wigley_mesh
            V, F = half_wigley_mesh(48, 16, B=B, T=T)
            write_ascii_stl(os.path.join(folder, "wigley_%02d.stl" % k), V, F)
        else:
            half_wigley_shape(1.0, B, T).exportStep(os.path.join(folder, "wigley_%02d.step" % k))
    return params


def write_ascii_stl(path, V, F):
    import numpy as np
    tri = V[F]
    nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    with open(path, "w") as fh:
        fh.write("solid wigley\n")
        for n, t in zip(nrm, tri):
            fh.write("facet normal %r %r %r\nouter loop\n" % tuple(n))
            fh.write("".join("vertex %r %r %r\n" % tuple(p) for p in t))
            fh.write("endloop\nendfacet\n")
        fh.write("endsolid wigley\n")


def measure(folder, out, settings, **kw):
    from hullprod_wb.batch import run_batch
    from hullprod_wb.batch.cases import expand_cases
    cases = expand_cases([folder])
    t0 = time.perf_counter()
    result = run_batch(cases, settings, out=out, resume=False, **kw)
    wall = time.perf_counter() - t0
    per_case = [r["runtime_s"] for r in result.rows if r.get("runtime_s")]
    for case_id, error in result.failures[:1]:
        print("  first failure: %s: %s" % (case_id, error))
    return len(cases), result.failed, wall, sum(per_case) / max(1, len(per_case))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=12)
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--mesh", action="store_true", help="STL meshes instead of STEP BReps")
    ap.add_argument("--dask", action="store_true", help="also a Dask LocalCluster with max(--workers) processes")
    ap.add_argument("--repeat", type=int, default=1, help="runs per setting; the fastest is reported")
    ap.add_argument("--option", action="append", default=[], metavar="KEY=VALUE",
                    help="assessment option (rtol, max_depth, order, display_deflection, ...), repeatable")
    args = ap.parse_args(argv)
    from hullprod_wb.batch.api import split_options
    from hullprod_wb.batch.cases import _parse_value
    options = {k: _parse_value(v) for k, _, v in (o.partition("=") for o in args.option)}
    settings = split_options(options)
    with tempfile.TemporaryDirectory(prefix="hullprod-bench-") as tmp:
        folder = os.path.join(tmp, "hulls")
        os.makedirs(folder)
        write_family(folder, args.cases, args.mesh)
        kind = "STL mesh (48 x 16 quads)" if args.mesh else "STEP BRep"
        print("half-Wigley family: %d %s cases, %d CPUs, load average %.1f" % (args.cases, kind, os.cpu_count(),
                                                                              os.getloadavg()[0]))
        print("options: %s" % (", ".join("%s=%s" % kv for kv in options.items()) or "defaults"))
        print("%-22s %6s %7s %10s %12s %10s" % ("runner", "cases", "failed", "wall [s]", "cases/min", "s/case"))
        runs = [("local, %d worker%s" % (w, "" if w == 1 else "s"), {"workers": w}) for w in args.workers]
        cluster = None
        if args.dask:
            from dask.distributed import LocalCluster
            n = max(args.workers)
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                                   dashboard_address=":0")
            runs.append(("dask local, %d workers" % n, {"scheduler": cluster.scheduler_address}))
        try:
            for k, (label, kw) in enumerate(runs):
                n, failed, wall, per_case = min((measure(folder, os.path.join(tmp, "out%d_%d" % (k, i)), settings, **kw)
                                                 for i in range(args.repeat)), key=lambda m: m[2])
                print("%-22s %6d %7d %10.2f %12.1f %10.3f" % (label, n, failed, wall, 60.0 * n / wall, per_case))
        finally:
            if cluster is not None:
                cluster.close()


if __name__ == "__main__":
    main()
