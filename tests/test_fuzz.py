"""The fuzz harness (fuzz_cases.py) in the normal suite: a few hundred seeded cases of
damaged hull files, each ending with exit 0 (finite values) or exit 2 (one line)."""
import json
import os
import subprocess

from conftest import ROOT, needs_freecad

HERE = os.path.dirname(os.path.abspath(__file__))

#: Cases and seed of the suite's run (run fuzz_cases.py alone for more).
CASES, SEED = 200, 20


@needs_freecad
def test_fuzz_cases_exit_0_or_2(tmp_path):
    # a driver process of its own: without FreeCAD loaded, as the command starts
    # the cases' files are a few kilobytes: OpenCascade's reader gets 5 s before a stall on a
    # damaged one counts as a refusal (exit 2), inside the cases' 10 s
    env = dict(os.environ, HULLPROD_READ_TIME_LIMIT="5")
    r = subprocess.run(["/usr/bin/python3", os.path.join(HERE, "fuzz_cases.py"), "--cases", str(CASES), "--seed",
                        str(SEED), "--limit", "10", "--json", "--keep", str(tmp_path)],
                       capture_output=True, text=True, timeout=900, cwd=ROOT, env=env)
    report = json.loads(r.stdout.strip().splitlines()[-1])
    outcomes = report["outcomes"]
    assert sum(outcomes.values()) == CASES
    assert outcomes.get("exit 2", 0) > CASES // 3 and outcomes.get("exit 0", 0) > 0, outcomes
    failures = report["failures"]
    assert not failures, "\n".join("%s %s: %s: %s" % tuple(f) for f in failures)
