"""Benchmark of the BRep path against the number of faces: a real hull's faces split into
about 100, 1,000 and 10,000 B-spline pieces of the same shape (bench/split_hull.py), each run
through the whole command at default settings, `./hullprod analyze FILE --json --lref L
--cache DIR` (the distributed fields on, and the faces' store on in a new empty folder a run:
cold, every face integrated and stored, as a first run on a new hull is).

    /usr/bin/python3 bench/brep_scale.py [--sizes 100,1000,10000] [--source FILE] [--jobs N]
        [--timeout S] [--keep DIR] [--no-fields] [--no-cache]

--no-fields and --no-cache are passed to the command (no fields; no store).

The source is ../shared/hulls/brep/kvlcc2_half_overture.igs (14 trimmed B-spline faces) when
present, else the built-in half-Wigley Bezier patch; it and every split are read and written
as OpenCascade .brep files by a child process (a damaged file can kill an OpenCascade reader;
.brep is written and read without translation, so the files hold exactly the split geometry
and the reading time does not swamp the analysis). The unsplit source runs first: its
automatic L_ref is given to every split (I_D scales with L_ref^2, and the automatic L_ref comes
from a triangulation that differs between splits; the split's own automatic value is printed).

One row a file: faces, wall seconds, CPU seconds (the command and its workers), peak resident
MB (the largest of the command's processes: RUSAGE_CHILDREN in a fresh wrapper process a
run), quadrature points, I_D with its error estimate, the metrics not VALID / VALID*, and the
growth exponent log(t / t_prev) / log(faces / faces_prev) (1: linear). Then the checks: the
represented area against the source's (1e-6 relative where the pieces tile the faces
exactly) and |I_D - I_D_source| against the sum of the two error estimates (the signature is
an area average: splitting must not change it). Prints figures only; asserts nothing.
"""
import argparse
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
KVLCC2 = os.path.normpath(os.path.join(ROOT, "..", "shared", "hulls", "brep", "kvlcc2_half_overture.igs"))
GOOD = ("VALID", "VALID*")
#: A fresh wrapper a run: its RUSAGE_CHILDREN is this command's alone.
WRAP = ("import resource, subprocess, sys\n"
        "with open(sys.argv[1], 'w') as out, open(sys.argv[2], 'w') as err:\n"
        "    r = subprocess.run(sys.argv[3:], stdout=out, stderr=err).returncode\n"
        "u = resource.getrusage(resource.RUSAGE_CHILDREN)\n"
        "print(u.ru_maxrss, u.ru_utime + u.ru_stime)\n"
        "sys.exit(r)\n")
HEARTBEAT = 30.0


def log(msg):
    sys.stderr.write("[%s] %s\n" % (time.strftime("%H:%M:%S"), msg))
    sys.stderr.flush()


def _write(source, folder, size):
    """The --write child: the source (size 0) or its split into about size faces as .brep;
    one JSON line of its path, faces, the split's methods and seconds."""
    sys.path.append("/usr/lib/freecad-python3/lib")
    sys.path.insert(0, ROOT)
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import FreeCAD  # noqa: F401 - before Part
    import Part
    import split_hull
    if source:
        shape = Part.read(source)
    else:
        from hullprod_wb.examples.builtin import half_wigley_shape
        shape = half_wigley_shape()
    if not shape.Faces:
        sys.exit("no faces in %s" % (source or "the built-in example"))
    t = time.perf_counter()
    how = {"source": len(shape.Faces)}
    if size:
        shape, how = split_hull.split_shape(shape, size, progress=lambda m: log("  " + m) if size >= 5000 else None)
    path = os.path.join(folder, "split_%d.brep" % size if size else "source.brep")
    shape.exportBrep(path)
    print(json.dumps({"path": path, "faces": len(shape.Faces), "how": how, "seconds": time.perf_counter() - t}))


def write_file(source, folder, size):
    p = subprocess.run([sys.executable, os.path.abspath(__file__), "--write", source or "", folder, str(size)],
                       stdout=subprocess.PIPE, text=True)
    if p.returncode != 0:
        raise RuntimeError("splitting into %d faces failed (exit %d)" % (size, p.returncode))
    return json.loads(p.stdout.strip().splitlines()[-1])


def run(path, lref, jobs, timeout, folder, options=()):
    """One whole command in a fresh wrapper: a dict of the figures, or with 'error'. Without
    --no-cache in options, the faces' store is a new folder in folder."""
    out, err = os.path.join(folder, "out.json"), os.path.join(folder, "err.txt")
    cmd = [os.path.join(ROOT, "hullprod"), "analyze", path, "--json"] + list(options)
    if "--no-cache" not in options:
        cmd += ["--cache", tempfile.mkdtemp(prefix="store-", dir=folder)]
    cmd += ["--lref", repr(lref)] if lref else []
    cmd += ["--jobs", str(jobs)] if jobs else []
    t = time.perf_counter()
    p = subprocess.Popen([sys.executable, "-c", WRAP, out, err] + cmd, stdout=subprocess.PIPE, text=True,
                         start_new_session=True)
    while True:
        try:
            rusage = p.communicate(timeout=HEARTBEAT)[0]
            break
        except subprocess.TimeoutExpired:
            wall = time.perf_counter() - t
            if wall > timeout:
                os.killpg(p.pid, signal.SIGKILL)  # the wrapper's group: the command and its workers
                p.communicate()
                return {"wall": wall, "error": "timeout after %.0f s" % timeout}
            last = open(err).read().strip().splitlines()[-1:] if os.path.exists(err) else []
            log("  %.0f s: %s" % (wall, last[0][:100] if last else ""))
    wall = time.perf_counter() - t
    peak_kb, cpu = rusage.split()
    res = {"wall": wall, "cpu": float(cpu), "peak_mb": int(peak_kb) / 1024.0}
    if p.returncode != 0:
        res["error"] = "exit %d: %s" % (p.returncode, open(err).read().strip()[-300:])
        return res
    doc = json.load(open(out))
    val = doc["validity"]
    secs = sorted(((sum(p.get("seconds", 0.0) for p in q.get("parts", [])), q["face"], q.get("n_points"))
                   for q in doc["provenance"].get("quadrature", [])), reverse=True)
    res.update(faces=doc["input"]["face_count"], points=doc["options"].get("points_evaluated"),
               I_D=doc["signature"]["I_D"], err=val["I_D"].get("evidence", {}).get("error_estimate"),
               area=doc["integrals"]["represented_area"], timings=doc.get("timings", {}),
               face_s=sum(x[0] for x in secs), slowest=secs[:3], lref=doc["reference_length"]["value"],
               lref_auto=doc["reference_length"]["automatic_value"],
               bad={k: (r.get("status") if isinstance(r, dict) else r) for k, r in val.items()
                    if (r.get("status") if isinstance(r, dict) else r) not in GOOD})
    return res


def _fmt(x, f):
    return "-" if x is None else f % x


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="100,1000,10000", help="target face counts (default 100,1000,10000)")
    ap.add_argument("--source", help="hull file to split, or 'builtin' (default: the shared KVLCC2, else the built-in)")
    ap.add_argument("--jobs", type=int, help="passed to the command (default: its own)")
    ap.add_argument("--timeout", type=float, default=1800.0, help="seconds a run (default 1800)")
    ap.add_argument("--keep", help="write the .brep files here and keep them")
    ap.add_argument("--no-fields", action="store_true", help="passed to the command: no distributed fields")
    ap.add_argument("--no-cache", action="store_true", help="passed to the command: no faces' store")
    ap.add_argument("--write", nargs=3, help=argparse.SUPPRESS)
    a = ap.parse_args()
    options = [o for o, on in (("--no-fields", a.no_fields), ("--no-cache", a.no_cache)) if on]
    if a.write:
        return _write(a.write[0], a.write[1], int(a.write[2]))
    source = KVLCC2 if os.path.exists(KVLCC2) and not a.source else a.source or ""
    source = "" if source == "builtin" else os.path.abspath(source) if source else ""
    sizes = sorted(int(float(s)) for s in a.sizes.split(","))
    folder = a.keep or tempfile.mkdtemp(prefix="hullprod-scale-")
    os.makedirs(folder, exist_ok=True)
    print("source: %s; load average %.2f (%d CPUs, shared); command options: %s"
          % (source or "built-in half-Wigley Bezier patch", os.getloadavg()[0], os.cpu_count(),
             " ".join(options) or "defaults (fields on, a new empty store a run)"))
    print("%7s %9s %8s %8s %8s %11s %22s  %s" % ("faces", "split [s]", "wall [s]", "CPU [s]", "peak MB", "points",
                                              "I_D +- error", "not VALID / exponent"))
    rows, lref = [], None
    try:
        for size in [0] + sizes:
            log("%s: writing" % ("source" if not size else "about %d faces" % size))
            w = write_file(source, folder, size)
            log("%d faces (%s) in %.1f s; analysing" % (w["faces"], w["how"], w["seconds"]))
            r = run(w["path"], lref, a.jobs, a.timeout, folder, options)
            r.update(written=w)
            if "error" in r:
                print("%7d %9.1f %8.1f  %s" % (w["faces"], w["seconds"], r["wall"], r["error"]), flush=True)
                if not size:
                    return 1
                break
            lref = lref or r["lref_auto"]
            prev = rows[-1] if rows else None
            expo = (math.log(r["wall"] / prev["wall"]) / math.log(r["faces"] / prev["faces"])
                    if prev and r["faces"] != prev["faces"] else None)
            print("%7d %9.1f %8.1f %8.1f %8.0f %11s %22s  %s / %s" % (
                r["faces"], w["seconds"], r["wall"], r["cpu"], r["peak_mb"], _fmt(r["points"], "%d"),
                "%.6g +- %.1e" % (r["I_D"], r["err"] or 0) if r["I_D"] is not None else "null",
                " ".join("%s %s" % kv for kv in r["bad"].items()) or "none", _fmt(expo, "%.2f")), flush=True)
            rows.append(r)
    finally:
        if not a.keep:
            shutil.rmtree(folder, ignore_errors=True)
    print("load average at the end %.2f" % os.getloadavg()[0])
    if not rows:
        return 1
    src = rows[0]
    print("\nphases of the JSON timings [s]; the faces' own quadrature seconds (sum, slowest: face seconds points);"
          " L_ref (given / the file's own automatic value); split methods (source faces):")
    for r in rows:
        t = r["timings"]
        print("%7d  %s  faces %.1f (%s)  L_ref %.10g / %.10g  %s" % (
            r["faces"], " ".join("%s %.1f" % (k[:-2], v) for k, v in t.items()), r["face_s"],
            ", ".join("%d %.1f %s" % (f, sec, n) for sec, f, n in r["slowest"]), r["lref"], r["lref_auto"],
            r["written"]["how"]))
    print("\nchecks against the unsplit source (%d faces): represented area %.10g, I_D %.8g +- %.1e"
          % (src["faces"], src["area"], src["I_D"], src["err"] or 0))
    for r in rows[1:]:
        exact = "centres" not in r["written"]["how"]
        darea = r["area"] / src["area"] - 1
        dI, tol = r["I_D"] - src["I_D"], (r["err"] or 0) + (src["err"] or 0)
        print("%7d  area %+.2e relative (%s, %s)   I_D %+.2e, |dI_D| / (sum of error estimates %.1e) = %.2f: %s"
              % (r["faces"], darea, "exact tiling" if exact else "centre fallback: not exact",
                 ("within 1e-6" if abs(darea) <= 1e-6 else "OUTSIDE 1e-6"), dI, tol,
                 abs(dI) / tol if tol else float("inf"), "within" if abs(dI) <= tol else "OUTSIDE"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
