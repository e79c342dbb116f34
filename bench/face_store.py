"""Cold against warm: what the faces' store (core.result_store) saves when a hull changes.

For each hull, one of its faces is changed as a designer would change it: an interior pole
of its B-spline surface moved along the surface normal (an untrimmed face of median area, so
that its p-curves stay exact; the face rebuilt on the moved surface over the same parameter
box). The hull's faces are written as base.brep and as variant_K.brep (the pole moved by
K steps of 1e-3 of the face's box diagonal), and the command runs side by side, in one run
of this script:
  - the first variant with --no-cache and with an empty store (a new folder each time),
    alternating, COLD_PAIRS times each (medians of the wall and of the CPU seconds of the
    command and the processes it waited for: what the store costs on misses; and the main
    process's own seconds in the store on the empty-store runs, timings.store_s);
  - the first variant after the base filled the store (one face changed: warm), its signature
    against the cold run's;
  - a family of N variants with a fresh store, as a multiple of one cold run (the median
    --no-cache run): as N commands one after another (the first cold, the others warm), as
    one `hullprod batch` on the local workers, and as one `hullprod batch` on a Dask
    LocalCluster of as many worker processes (--no-dask: not). The batch's workers share the
    store: a face one of them is integrating, the others await (core.result_claims).

    /usr/bin/python3 bench/face_store.py [--hull FILE ...] [--variants N] [--keep DIR] [--no-dask]

Default hulls: the shared closed KCS (125 faces) and fcship (449 faces).
"""
import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.append("/usr/lib/freecad-python3/lib")
HULLS = os.path.normpath(os.path.join(ROOT, "..", "shared", "hulls", "brep"))
DEFAULT = ("kcs_full_closed_ohp.iges", "fcship_half_wavebem.iges")
#: The pole's step, as a fraction of the changed face's bounding-box diagonal.
STEP = 1e-3
#: Cold runs without and with an empty store, alternating (medians compared).
COLD_PAIRS = 5


def changed_face(faces):
    """Index of the face to change: among untrimmed B-spline faces with interior poles, the one
    of median area."""
    import Part
    from split_hull import uv_face
    cand = []
    for i, f in enumerate(faces):
        s = f.Surface
        if not isinstance(s, Part.BSplineSurface) or s.NbUPoles < 3 or s.NbVPoles < 3:
            continue
        u0, u1, v0, v1 = f.ParameterRange
        try:
            full = abs(uv_face(f).Area - (u1 - u0) * (v1 - v0)) <= 1e-9 * (u1 - u0) * (v1 - v0)
        except Exception:  # noqa: BLE001 - a domain OpenCascade cannot rebuild: not a candidate
            full = False
        try:
            area = f.Area
        except Exception:  # noqa: BLE001 - OpenCascade cannot give its area: not a candidate
            continue
        if full:
            cand.append((area, i))
    if not cand:
        raise SystemExit("no untrimmed B-spline face with interior poles to change")
    cand.sort()
    return cand[len(cand) // 2][1]


def moved(face, dz):
    """face rebuilt on its surface with the middle pole moved by dz along the normal."""
    s = face.Surface.copy()
    i, j = (s.NbUPoles + 1) // 2, (s.NbVPoles + 1) // 2
    u0, u1, v0, v1 = face.ParameterRange
    n = s.normal((u0 + u1) / 2, (v0 + v1) / 2)
    s.setPole(i, j, s.getPole(i, j) + n * dz)
    out = s.toShape(u0, u1, v0, v1)
    if face.Orientation == "Reversed":
        out.reverse()
    return out


def write_variants(path, folder, n):
    """base.brep and variant_1..n.brep in folder; returns (face number changed, its area share)."""
    import FreeCAD  # noqa: F401 - before Part
    import Part
    shape = Part.read(path)
    faces = list(shape.Faces)
    k = changed_face(faces)
    step = STEP * faces[k].BoundBox.DiagonalLength
    Part.Compound(faces).exportBrep(os.path.join(folder, "base.brep"))
    for v in range(1, n + 1):
        out = list(faces)
        out[k] = moved(faces[k], v * step)
        Part.Compound(out).exportBrep(os.path.join(folder, "variant_%d.brep" % v))
    def area(f):
        try:
            return f.Area
        except Exception:  # noqa: BLE001 - a face OpenCascade gives no area: none counted
            return 0.0
    return k + 1, area(faces[k]) / sum(area(f) for f in faces)


def run(path, store, cpu=None):
    """(wall seconds, JSON document) of the command on path; store: a folder, or None
    (--no-cache). cpu: a list to which the run's CPU seconds are appended (user and system, of
    the command and the processes it waited for: its reading process and workers)."""
    cmd = [os.path.join(ROOT, "hullprod"), "analyze", path, "--json", "--quiet"]
    cmd += ["--cache", store] if store else ["--no-cache"]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        raise SystemExit("%s: exit %d: %s" % (" ".join(cmd), p.returncode, p.stderr.strip()[-400:]))
    if cpu is not None:
        cpu.append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
    return wall, json.loads(p.stdout)


def run_batch(paths, store, out, scheduler=None):
    """Wall seconds of one `hullprod batch` of paths with the store folder (on the Dask
    scheduler's workers, else the local ones)."""
    cmd = [os.path.join(ROOT, "hullprod"), "batch"] + paths + ["--cache", store, "--out", out, "--quiet"]
    cmd += ["--scheduler", scheduler] if scheduler else []
    t = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t
    if p.returncode != 0 or " 0 failed" not in p.stdout:
        raise SystemExit("%s: exit %d: %s" % (" ".join(cmd), p.returncode, (p.stdout + p.stderr).strip()[-400:]))
    return wall


def bench(path, n, work, scheduler):
    number, share = write_variants(path, work, n)
    variant = [os.path.join(work, "variant_%d.brep" % v) for v in range(1, n + 1)]
    store = lambda name: os.path.join(work, "store-" + name)  # noqa: E731
    offs, empties, own, cpu_off, cpu_empty = [], [], [], [], []
    for k in range(COLD_PAIRS):  # alternating: the machine's drift falls on both alike
        t, cold = run(variant[0], None, cpu_off)
        offs.append(t)
        # a folder of its own: entries written just after the last run's were removed would
        # wait on the file system (ext4 allocates no recently freed inode), as a first run does not
        t, doc = run(variant[0], store("empty-%d" % k), cpu_empty)
        empties.append(t)
        own.append(doc["timings"]["store_s"])
    t_base, _ = run(os.path.join(work, "base.brep"), store("warm"))
    t_warm, warm = run(variant[0], store("warm"))
    same = warm["signature"] == cold["signature"] and warm["validity"] == cold["validity"]
    family = [run(p, store("family"))[0] for p in variant]
    local = run_batch(variant, store("batch"), os.path.join(work, "out-batch"))
    dask = scheduler and run_batch(variant, store("dask"), os.path.join(work, "out-dask"), scheduler)
    c = warm["provenance"]["cache"]
    return {"hull": os.path.basename(path), "faces": len(cold["provenance"]["faces"]), "changed": number,
            "share": share, "cold": statistics.median(offs), "cold_empty_store": statistics.median(empties),
            "store_s": statistics.median(own), "cpu": statistics.median(cpu_off),
            "cpu_empty_store": statistics.median(cpu_empty),
            "base": t_base, "warm": t_warm, "hits": c["hits"], "misses": c["misses"], "identical": same,
            "family": sum(family), "batch": local, "dask": dask, "cold_median": statistics.median(offs), "n": n}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hull", action="append", help="BRep file (repeatable; default: %s)" % ", ".join(DEFAULT))
    ap.add_argument("--variants", type=int, default=20, help="variants of the family (default 20)")
    ap.add_argument("--keep", help="write the variants and stores here and keep them")
    ap.add_argument("--no-dask", action="store_true", help="no family on a Dask LocalCluster")
    args = ap.parse_args()
    hulls = args.hull or [os.path.join(HULLS, h) for h in DEFAULT if os.path.isfile(os.path.join(HULLS, h))]
    if not hulls:
        raise SystemExit("no hull: give --hull FILE (../shared/hulls is absent)")
    cluster = None
    if not args.no_dask:
        from dask.distributed import LocalCluster
        from hullprod_wb.batch.runner import worker_environ
        with worker_environ():  # the workers start as a batch's local workers do
            cluster = LocalCluster(n_workers=os.cpu_count(), threads_per_worker=1, processes=True, host="127.0.0.1",
                                   dashboard_address=":0")
    try:
        rows = [bench_hull(h, args, cluster and cluster.scheduler_address) for h in hulls]
    finally:
        if cluster is not None:
            cluster.close()
    print()
    print("| hull | faces | cold --no-cache [s] | cold, empty store [s] | CPU cold / empty store [s] | "
          "one face changed, warm [s] | warm / cold | same signature | family of N: commands / cold | batch / cold | "
          "Dask / cold |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print("| %s | %d | %.2f | %.2f (%+.1f %%; store's own work %.3f s) | %.2f / %.2f (%+.1f %%) | %.2f | %.2f | %s "
              "| %.2f (N = %d) | %.2f | %s |"
              % (r["hull"], r["faces"], r["cold"], r["cold_empty_store"], 100 * (r["cold_empty_store"] / r["cold"] - 1),
                 r["store_s"], r["cpu"], r["cpu_empty_store"], 100 * (r["cpu_empty_store"] / r["cpu"] - 1),
                 r["warm"], r["warm"] / r["cold"], "yes" if r["identical"] else "NO", r["family"] / r["cold_median"],
                 r["n"], r["batch"] / r["cold_median"],
                 "%.2f" % (r["dask"] / r["cold_median"]) if r["dask"] else "-"))


def bench_hull(h, args, scheduler):
    """The row of hull file h (its variants written in a temporary folder, or in --keep)."""
    work = args.keep and os.path.join(args.keep, os.path.splitext(os.path.basename(h))[0])
    if work:
        os.makedirs(work, exist_ok=True)
    else:
        work = tempfile.mkdtemp(prefix="hullprod-store-bench-")
    try:
        r = bench(h, args.variants, work, scheduler)
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)
    print("%s: face %d changed (%.2g of the area); cold %.2f s (empty store %.2f s), warm %.2f s "
          "(%d hits, %d misses), same signature and validity: %s; family of %d: commands %.1f s, batch %.1f s%s "
          "(cold %.2f s)" % (r["hull"], r["changed"], r["share"], r["cold"], r["cold_empty_store"], r["warm"], r["hits"],
                             r["misses"], r["identical"], r["n"], r["family"], r["batch"],
                             ", Dask %.1f s" % r["dask"] if r["dask"] else "", r["cold_median"]), flush=True)
    return r


if __name__ == "__main__":
    main()
