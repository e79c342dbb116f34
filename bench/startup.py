"""Whole-command start-up of two checkouts, side by side: alternating runs of
ROOT/hullprod ARGS --quiet, medians of the wall time and of the CPU time (user + system,
the command's reading and worker processes included: getrusage(RUSAGE_CHILDREN)).

usage: /usr/bin/python3 bench/startup.py N ROOT_A ROOT_B -- analyze FILE [options]
"""
import os
import resource
import statistics
import subprocess
import sys
import time

# cold runs: every face integrated, none taken from a store of faces (core.result_store)
os.environ["HULLPROD_FACE_CACHE"] = "off"


def main(argv):
    n, split = int(argv[0]), argv.index("--")
    roots, args = argv[1:split], argv[split + 1:]
    runs = {r: ([], []) for r in roots}
    for _ in range(n):
        for r in roots:
            before, t = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter()
            p = subprocess.run([r + "/hullprod"] + args + ["--quiet"], stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL)
            wall, after = time.perf_counter() - t, resource.getrusage(resource.RUSAGE_CHILDREN)
            if p.returncode != 0:
                sys.exit("%s/hullprod %s: exit %d" % (r, " ".join(args), p.returncode))
            runs[r][0].append(wall)
            runs[r][1].append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    for r, (wall, cpu) in runs.items():
        print("%-30s %-45s wall %.3f s  cpu %.3f s  (medians of %d)"
              % (r, " ".join(a.split("/")[-1] for a in args), statistics.median(wall), statistics.median(cpu), n))


if __name__ == "__main__":
    main(sys.argv[1:])
