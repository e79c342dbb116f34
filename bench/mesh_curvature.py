"""Benchmark of the mesh path at scan scale: the whole command `./hullprod analyze FILE
--json --quiet --lref 8` on generated closed tori (R = 3, r = 1, random diagonals) of about
0.1M, 1M and 4M vertices, written as binary STL, binary PLY and OBJ.

    /usr/bin/python3 bench/mesh_curvature.py [--sizes 0.1,1,4] [--formats stl,ply,obj]
        [--repeat 5] [--reference] [--venv DIR] [--keep DIR]

For every file: the median wall time of --repeat runs with the smallest and largest (the
noise of a shared machine), the median of each phase of the JSON `timings` (load, quality,
curvature, signature; the quality record is measured on a second thread inside the load),
the median user and system CPU seconds and the peak resident memory of the command (its
own rusage; the system time is mostly the kernel's zeroing of fresh pages). With
several sizes, the ratio of the median times 4M / 1M of each format, measured in this
same run (linear cost: 4x the vertices, about 4x the time). With --reference, the paper's
reference package (hullprod 1.0.1 from PyPI, in a throwaway virtual environment, a fresh
result cache each run) runs the 1M files of the binary formats once each, between our
runs, and the time ratio is printed. The meshes are generated into a temporary folder
(removed at the end unless --keep). Prints figures only; asserts nothing.
"""
import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from reference_venv import ensure_reference_venv  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

#: Quads around the tube per size (millions of vertices): n x 3n grid, 3 n^2 vertices.
TUBE_QUADS = {0.1: 183, 1.0: 577, 4.0: 1155}
LREF = 8.0
PHASES = ("load_s", "quality_s", "curvature_s", "signature_s")


def write_meshes(folder, size, formats):
    """Paths {format: file}, vertices, faces of the torus of about size million vertices,
    written by a child process (so that this process stays small: a child inherits the
    peak resident memory of the process it is started from in its own rusage)."""
    out = subprocess.run([sys.executable, os.path.abspath(__file__), "--write", folder, str(size),
                          ",".join(formats)], capture_output=True, text=True, check=True).stdout
    doc = json.loads(out)
    return doc["paths"], doc["vertices"], doc["faces"]


def _write(folder, size, formats):
    """The --write child: the torus files, and a JSON line of their paths and counts."""
    import trimesh
    from hullprod_wb.examples.analytic_meshes import torus_mesh
    V, F = torus_mesh(TUBE_QUADS[size], pattern="random", seed=1)
    mesh = trimesh.Trimesh(V, F, process=False)
    paths = {}
    for fmt in formats:
        paths[fmt] = os.path.join(folder, "torus_%gM.%s" % (size, fmt))
        mesh.export(paths[fmt])
    print(json.dumps({"paths": paths, "vertices": len(V), "faces": len(F)}))


def timed_child(cmd, env=None):
    """(stdout, stderr, exit status, wall seconds, peak resident MB, (user, system) CPU
    seconds) of one command; memory and CPU are the child's own (os.wait4), not the largest
    child's so far."""
    t = time.perf_counter()
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    out, err = p.stdout.read(), p.stderr.read()
    _, status, usage = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t
    p.stdout.close()
    p.stderr.close()
    p.returncode = os.waitstatus_to_exitcode(status)
    return (out, err.decode(errors="replace"), p.returncode, wall, usage.ru_maxrss / 1024.0,
            (usage.ru_utime, usage.ru_stime))


def run_ours(path):
    """One run of our command: dict(wall, rss, user, sys, timings, I_D) or dict(wall, error)."""
    cmd = [os.path.join(ROOT, "hullprod"), "analyze", path, "--json", "--quiet", "--lref", str(LREF)]
    out, err, code, wall, rss, (user, system) = timed_child(cmd)
    if code != 0:
        return {"wall": wall, "error": err.strip()[-300:]}
    doc = json.loads(out)
    return {"wall": wall, "rss": rss, "user": user, "sys": system, "timings": doc["timings"],
            "I_D": doc["signature"]["I_D"]}


def run_reference(exe, path):
    """One run of the reference package with a fresh result cache: dict(wall, rss[, error])."""
    out = tempfile.mkdtemp(prefix="hullprod-ref-")
    cache = tempfile.mkdtemp(prefix="hullprod-ref-cache-")
    cmd = [exe, path, "--out", out, "--overwrite", "--no-plots", "--quiet", "--lref", str(LREF)]
    _, err, code, wall, rss, _ = timed_child(cmd, env=dict(os.environ, HULLPROD_CACHE_DIR=cache))
    shutil.rmtree(cache, ignore_errors=True)
    shutil.rmtree(out, ignore_errors=True)
    res = {"wall": wall, "rss": rss}
    if code != 0:
        res["error"] = err.strip()[-300:]
    return res


def summarise(runs):
    walls = [r["wall"] for r in runs]
    row = {"median": statistics.median(walls), "min": min(walls), "max": max(walls),
           "rss": max(r["rss"] for r in runs)}
    for ph in PHASES:
        row[ph] = statistics.median(r["timings"][ph] for r in runs)
    for cpu in ("user", "sys"):
        row[cpu] = statistics.median(r[cpu] for r in runs)
    row["I_D"] = runs[0]["I_D"]
    return row


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] == "--write":
        _write(argv[1], float(argv[2]), argv[3].split(","))
        return 0
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="0.1,1,4", help="millions of vertices, of %s" % sorted(TUBE_QUADS))
    ap.add_argument("--formats", default="stl,ply,obj")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--reference", action="store_true", help="also run hullprod 1.0.1 on the 1M binary files")
    ap.add_argument("--venv", default=os.path.join(tempfile.gettempdir(), "hullprod-ref-venv"))
    ap.add_argument("--keep", default=None, metavar="DIR", help="write the meshes here and keep them")
    args = ap.parse_args(argv)
    sizes = [float(s) for s in args.sizes.split(",")]
    formats = args.formats.split(",")
    exe = ensure_reference_venv(args.venv) if args.reference else None
    subprocess.run([sys.executable, "-m", "compileall", "-q", "-f", os.path.join(ROOT, "hullprod_wb")], check=True)
    folder = args.keep or tempfile.mkdtemp(prefix="hullprod-mesh-bench-")
    os.makedirs(folder, exist_ok=True)
    print("cores: %d, load average at start: %.2f (wall times grow when other processes share the cores)"
          % (os.cpu_count() or 1, os.getloadavg()[0]))
    print("%-18s %9s %8s %8s %20s %7s %7s %7s %7s %7s %7s %8s" % (
        "file", "vertices", "faces", "median", "min..max [s]", "load", "quality", "curv.", "sign.", "user",
        "system", "peak MB"))
    results = {}
    try:
        for size in sizes:
            paths, nv, nf = write_meshes(folder, size, formats)
            for fmt in formats:
                runs, ref = [], None
                for i in range(max(1, args.repeat)):
                    runs.append(run_ours(paths[fmt]))
                    if "error" in runs[-1]:
                        print("%s: %s" % (os.path.basename(paths[fmt]), runs[-1]["error"]))
                        break
                    if exe and size == 1.0 and fmt in ("stl", "ply") and i == 0:
                        ref = run_reference(exe, paths[fmt])
                runs = [r for r in runs if "error" not in r]
                if not runs:
                    continue
                row = summarise(runs)
                results[(size, fmt)] = row
                print("%-18s %9d %8d %8.2f %9.2f .. %7.2f %7.2f %7.2f %7.2f %7.2f %7.2f %7.2f %8.0f" % (
                    os.path.basename(paths[fmt]), nv, nf, row["median"], row["min"], row["max"],
                    row["load_s"], row["quality_s"], row["curvature_s"], row["signature_s"], row["user"],
                    row["sys"], row["rss"]))
                if ref is not None:
                    if "error" in ref:
                        print("%-18s reference hullprod 1.0.1: error %s" % ("", ref["error"]))
                    else:
                        print("%-18s reference hullprod 1.0.1: %.1f s, peak %.0f MB: %.1fx our median" % (
                            "", ref["wall"], ref["rss"], ref["wall"] / row["median"]))
                sys.stdout.flush()
            for fmt in formats:
                os.remove(paths[fmt])
    finally:
        if not args.keep:
            shutil.rmtree(folder, ignore_errors=True)
    for fmt in formats:
        if (1.0, fmt) in results and (4.0, fmt) in results:
            print("linearity %s: 4M / 1M median time %.2f" % (fmt, results[(4.0, fmt)]["median"] / results[(1.0, fmt)]["median"]))
    print("load average at the end: %.2f" % os.getloadavg()[0])
    return 0


if __name__ == "__main__":
    sys.exit(main())
