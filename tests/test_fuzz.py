"""The fuzz harness (fuzz_cases.py) in the normal suite: a few hundred seeded cases of
damaged hull files, each ending with exit 0 (finite values) or exit 2 (one line)."""
import json
import os
import subprocess
import sys

import pytest

from conftest import ROOT, needs_freecad

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from fuzz_cases import reader_ended  # noqa: E402

#: Cases and seed of the suite's run (run fuzz_cases.py alone for more).
CASES, SEED = 200, 20


@needs_freecad
def test_fuzz_cases_exit_0_or_2(tmp_path):
    # a driver process of its own: without FreeCAD loaded, as the command starts
    r = subprocess.run(["/usr/bin/python3", os.path.join(HERE, "fuzz_cases.py"), "--cases", str(CASES), "--seed",
                        str(SEED), "--limit", "10", "--json", "--keep", str(tmp_path)],
                       capture_output=True, text=True, timeout=900, cwd=ROOT)
    report = json.loads(r.stdout.strip().splitlines()[-1])
    outcomes = report["outcomes"]
    assert sum(outcomes.values()) == CASES
    assert outcomes.get("exit 2", 0) > CASES // 3 and outcomes.get("exit 0", 0) > 0, outcomes
    failures = report["failures"]
    ours = [f for f in failures if not reader_ended(f[2], f[3], f[0])]
    assert not ours, "\n".join("%s %s: %s: %s" % tuple(f) for f in ours)
    if failures:  # OpenCascade's reader ended or stalled the process: it must read in a child
        pytest.xfail("%d of %d cases: OpenCascade's reader ended or stalled the process reading the file (%s)"
                     % (len(failures), CASES, "; ".join("%s %s" % (f[0], f[2]) for f in failures)))
