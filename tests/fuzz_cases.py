"""Fuzz harness: seeded mutations of small generated hull files, each run through
`hullprod analyze`; every case must end with exit 0 (and finite metric values) or exit 2
with a one-line reason, within a time limit.

Run alone:  /usr/bin/python3 tests/fuzz_cases.py --cases 2000 --seed 7
The cases run as children forked from a driver process that has the command's modules
loaded but not FreeCAD (so BRep files are read as the command reads them); a child killed
by a signal, an exit 1, a traceback or a hang is reported as such.
"""
import argparse
import collections
import json
import math
import os
import random
import re
import signal
import struct
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
#: Seconds a case may take.
CASE_TIME_LIMIT = 60.0
#: Options of every case: a shallow quadrature (the outcome contract, not the accuracy).
#: Progress messages stay on: a hang is reported with the last one.
CASE_OPTIONS = ["--json", "--no-fields", "--max-depth", "2", "--order", "3"]

PROGRESS = re.compile(r"\[\s*\d+%\] ")
BREP_BASES = ("iges", "step", "brep")
MESH_BASES = ("stl", "stl_ascii", "ply", "ply_ascii", "obj")
EXTENSIONS = {"iges": ".igs", "step": ".step", "brep": ".brep", "stl": ".stl", "stl_ascii": ".stl",
              "ply": ".ply", "ply_ascii": ".ply", "obj": ".obj"}

GENERATE_BREP = r"""
import sys
sys.path.append('/usr/lib/freecad-python3/lib')
import FreeCAD, Part
out = sys.argv[1]
faces = []
for k in range(2):
    pts = [[FreeCAD.Vector(1000.0 * i + 4000.0 * k, 300.0 * j, 40.0 * (i - 1.5) ** 2 - 25.0 * (j - 1.5) ** 2)
            for j in range(4)] for i in range(5)]
    s = Part.BSplineSurface()
    s.interpolate(pts)
    faces.append(s.toShape())
shape = Part.makeShell(faces)
shape.exportIges(out + '/base.igs')
shape.exportStep(out + '/base.step')
shape.exportBrep(out + '/base.brep')
"""


def generate_bases(folder):
    """Write the base files of every format into folder; {base name: path}."""
    import numpy as np
    import trimesh
    subprocess.run([sys.executable, "-c", GENERATE_BREP, folder], check=True, capture_output=True, timeout=120)
    n = 12
    x, y = np.meshgrid(np.linspace(0.0, 10.0, n), np.linspace(0.0, 3.0, n), indexing="ij")
    z = 0.05 * (x - 5.0) ** 2 - 0.2 * (y - 1.5) ** 2
    v = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    f = np.vstack([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    mesh = trimesh.Trimesh(v, f, process=False)
    paths = {name: os.path.join(folder, "base" + EXTENSIONS[name]) for name in BREP_BASES}
    for name, kw in (("stl", {}), ("stl_ascii", {"file_type": "stl_ascii"}), ("ply", {"encoding": "binary"}),
                     ("ply_ascii", {"encoding": "ascii"}), ("obj", {})):
        path = os.path.join(folder, "base_%s%s" % (name, EXTENSIONS[name]))
        data = trimesh.exchange.export.export_mesh(mesh, None, file_type=kw.pop("file_type", EXTENSIONS[name][1:]),
                                                   **kw)
        with open(path, "wb") as fh:
            fh.write(data if isinstance(data, bytes) else data.encode())
        paths[name] = path
    return paths


# -- mutations --------------------------------------------------------------------------------

NUMBER = re.compile(rb"[-+]?\d+\.\d*(?:[eEdD][-+]?\d+)?")
BAD_NUMBERS = (b"nan", b"NaN", b"inf", b"-inf", b"1e308", b"-1e308", b"1e999", b"1.0E+300", b"0.0")


def truncate(data, rng, base):
    return data[:max(1, int(len(data) * rng.uniform(0.02, 0.999)))]


def overwrite(data, rng, base):
    out = bytearray(data)
    start = rng.randrange(len(out))
    for i in range(start, min(len(out), start + rng.randint(1, 16))):
        out[i] = rng.randrange(256)
    return bytes(out)


def delete_line(data, rng, base):
    lines = data.split(b"\n")
    if len(lines) < 3:
        return truncate(data, rng, base)
    del lines[rng.randrange(len(lines))]
    return b"\n".join(lines)


def swap_sections(data, rng, base):
    """Two blocks of lines exchanged (IGES sections, STEP entities, mesh records)."""
    lines = data.split(b"\n")
    if len(lines) < 6:
        return overwrite(data, rng, base)
    i, j = sorted(rng.sample(range(len(lines)), 2))
    k = rng.randint(1, max(1, min(j - i, len(lines) - j, 20)))
    lines[i:i + k], lines[j:j + k] = lines[j:j + k], lines[i:i + k]
    return b"\n".join(lines)


def bad_number(data, rng, base):
    if base in ("stl", "ply"):  # binary: a float of the data overwritten
        head = data.find(b"end_header\n") + 11 if base == "ply" else 84
        if len(data) - head < 8:
            return overwrite(data, rng, base)
        at = head + 4 * rng.randrange((len(data) - head) // 4)
        value = rng.choice((float("nan"), float("inf"), -float("inf"), 1e38, -3e38))
        return data[:at] + struct.pack("<f", value) + data[at + 4:]
    found = list(NUMBER.finditer(data))
    if not found:
        return overwrite(data, rng, base)
    out = data
    for m in sorted(rng.sample(found, min(len(found), rng.randint(1, 3))), key=lambda m: -m.start()):
        out = out[:m.start()] + rng.choice(BAD_NUMBERS) + out[m.end():]
    return out


def zero_faces(data, rng, base):
    if base == "stl":
        return data[:80] + struct.pack("<I", 0)
    if base == "stl_ascii":
        return b"solid empty\nendsolid empty\n"
    if base in ("ply", "ply_ascii"):
        head, _, body = data.partition(b"end_header\n")
        nv = int(re.search(rb"element vertex (\d+)", head).group(1))
        head = re.sub(rb"element face \d+", b"element face 0", head)
        if base == "ply_ascii":
            return head + b"end_header\n" + b"\n".join(body.split(b"\n")[:nv]) + b"\n"
        vsize = 4 * len(re.findall(rb"property float", head.split(b"element face")[0]))
        return head + b"end_header\n" + body[:nv * vsize]
    if base == "obj":
        return b"\n".join(line for line in data.split(b"\n") if not line.startswith(b"f "))
    return truncate(data, rng, base)


def degenerate_triangles(data, rng, base):
    if base == "stl":
        n = struct.unpack("<I", data[80:84])[0]
        out = bytearray(data)
        for _ in range(rng.randint(1, 5)):
            t = 84 + 50 * rng.randrange(n)
            out[t + 24:t + 36] = out[t + 12:t + 24]  # second vertex = first
        return bytes(out)
    if base in ("obj", "ply_ascii"):  # triangle lines "f a b c" / "3 a b c": second vertex = first
        head = b"f " if base == "obj" else b"3 "
        lines = data.split(b"\n")
        fi = [i for i, line in enumerate(lines) if line.startswith(head)]
        for i in rng.sample(fi, min(len(fi), rng.randint(1, 5))):
            w = lines[i].split()
            lines[i] = b" ".join([w[0], w[1], w[1], w[2]])
        return b"\n".join(lines)
    return bad_number(data, rng, base)


MUTATIONS = [(truncate, 4), (overwrite, 3), (delete_line, 1), (swap_sections, 1), (bad_number, 2),
             (zero_faces, 1), (degenerate_triangles, 1)]


def make_cases(n, seed, bases, folder):
    """n (case name, path) pairs of mutated files written into folder, from seed."""
    rng = random.Random(seed)
    names, weights = zip(*MUTATIONS)
    base_data = {b: open(p, "rb").read() for b, p in bases.items()}
    out = []
    for k in range(n):
        base = rng.choice(sorted(base_data))
        mutate = rng.choices(names, weights)[0]
        data = mutate(base_data[base], rng, base)
        path = os.path.join(folder, "case%04d_%s_%s%s" % (k, base, mutate.__name__, EXTENSIONS[base]))
        with open(path, "wb") as fh:
            fh.write(data)
        out.append(("%s/%s" % (base, mutate.__name__), path))
    return out


# -- running ----------------------------------------------------------------------------------


def finite_or_null(doc):
    """Names of the metric values of a JSON document that are not finite (or not numbers)."""
    bad = []
    for m, rec in (doc.get("validity") or {}).items():
        v = rec.get("value") if isinstance(rec, dict) else None
        if v is not None and not (isinstance(v, (int, float)) and math.isfinite(v)):
            bad.append(m)
    for m, v in (doc.get("signature") or {}).items():
        if v is not None and isinstance(v, (int, float)) and not math.isfinite(v):
            bad.append(m)
    return bad


def run_case(path, limit=CASE_TIME_LIMIT):
    """(outcome, detail) of `hullprod analyze path` run in a forked child of this process:
    outcome 'exit 0', 'exit 2' (the contract), or 'exit N', 'signal NAME', 'hang',
    'traceback', 'two-line reason', 'non-finite', 'bad json' (failures)."""
    from hullprod_wb import cli
    out = tempfile.TemporaryFile()
    err = tempfile.TemporaryFile()
    pid = os.fork()
    if pid == 0:
        code = 1
        try:
            os.dup2(out.fileno(), 1)
            os.dup2(err.fileno(), 2)
            sys.stdout = os.fdopen(1, "w", closefd=False)
            sys.stderr = os.fdopen(2, "w", closefd=False)
            os.setpgid(0, 0)
            code = cli.main(["analyze", path] + CASE_OPTIONS)
        except BaseException:
            import traceback
            traceback.print_exc()
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(1 if code is None else int(code))
    t0 = time.monotonic()
    status = None
    while time.monotonic() - t0 < limit:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            break
        time.sleep(0.01)
    else:
        try:
            os.killpg(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        os.waitpid(pid, 0)
        err.seek(0)
        last = err.read().decode("utf-8", "replace").strip().splitlines()[-1:] or ["no message"]
        return "hang", "over %.0f s after %s" % (limit, last[0])
    out.seek(0)
    err.seek(0)
    stdout, stderr = out.read().decode("utf-8", "replace"), err.read().decode("utf-8", "replace")
    lines = [line for line in stderr.splitlines()
             if line.strip() and not line.startswith("warning:") and not PROGRESS.match(line)]
    if os.WIFSIGNALED(status):
        return "signal %s" % signal.Signals(os.WTERMSIG(status)).name, stderr[-300:]
    code = os.WEXITSTATUS(status)
    if "Traceback" in stderr:
        return "traceback", stderr[-600:]
    if code == 2:
        if len(lines) != 1 or not lines[0].startswith("hullprod: error: "):
            return "two-line reason", stderr[-600:]
        return "exit 2", lines[0]
    if code == 0:
        try:
            doc = json.loads(stdout)
        except ValueError:
            return "bad json", stdout[:300]
        bad = finite_or_null(doc)
        return ("non-finite", ", ".join(bad)) if bad else ("exit 0", "")
    return "exit %d" % code, stderr[-300:]


def reader_ended(outcome, detail, name):
    """Whether a failure is OpenCascade's reader ending or stalling the process that reads a
    BRep file (a death by signal, an exit without a message, a hang while reading)."""
    if name.split("/")[0] not in BREP_BASES:
        return False
    detail = "\n".join(line for line in detail.splitlines() if not PROGRESS.match(line))
    if outcome.startswith("signal") or (outcome.startswith("exit") and not detail.strip()):
        return True
    return outcome == "hang" and detail.rstrip().endswith("] reading BRep")


def run_fuzz(n, seed, folder, limit=CASE_TIME_LIMIT, bases=None, log=None):
    """Run n cases of seed in folder: (Counter of outcomes, [(case, path, outcome, detail)]
    of the cases outside the contract, seconds)."""
    t0 = time.monotonic()
    base_paths = generate_bases(folder)
    if bases:
        base_paths = {b: p for b, p in base_paths.items() if b in bases}
    tally, bad = collections.Counter(), []
    for name, path in make_cases(n, seed, base_paths, folder):
        outcome, detail = run_case(path, limit)
        tally[outcome] += 1
        if outcome not in ("exit 0", "exit 2"):
            bad.append((name, path, outcome, detail))
        if log:
            log("%-34s %-10s %s" % (name, outcome, detail[:150].replace("\n", " | ")))
    return tally, bad, time.monotonic() - t0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=300)
    ap.add_argument("--seed", type=int, default=20)
    ap.add_argument("--limit", type=float, default=CASE_TIME_LIMIT, help="seconds a case may take")
    ap.add_argument("--keep", default=None, help="folder to keep the cases in (default: a temporary one)")
    ap.add_argument("--verbose", action="store_true", help="one line a case")
    ap.add_argument("--json", action="store_true", help="print the tally and failures as JSON")
    a = ap.parse_args(argv)
    sys.path.insert(0, ROOT)
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    import numpy  # noqa: F401  (loaded once here, not in every case)
    folder = a.keep or tempfile.mkdtemp(prefix="hullprod-fuzz-")
    os.makedirs(folder, exist_ok=True)
    tally, bad, seconds = run_fuzz(a.cases, a.seed, folder, a.limit,
                                   log=(lambda s: print(s, flush=True)) if a.verbose else None)
    if a.json:
        print(json.dumps({"cases": a.cases, "seed": a.seed, "seconds": seconds, "outcomes": dict(tally),
                          "failures": [list(b) for b in bad]}))
    else:
        print("%d cases (seed %d) in %.1f s: %s" % (a.cases, a.seed, seconds,
                                                    ", ".join("%s %d" % kv for kv in sorted(tally.items()))))
        for name, path, outcome, detail in bad:
            print("FAIL %s %s: %s: %s" % (name, path, outcome, " ".join(detail.split())[:300]))
    if not a.keep:
        import shutil
        shutil.rmtree(folder, ignore_errors=True)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
