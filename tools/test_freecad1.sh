#!/bin/bash
# The README's two commands on FreeCAD 1.x: Debian 13 (FreeCAD 1.0.0, OpenCascade 7.8, Python 3.13,
# numpy 2) in a chroot, built by ../shared/tools/debian13-chroot.sh the first time (as root: a few
# minutes and about 2.6 GB), each run in a fresh clone of this repository's committed HEAD.
# Usage: bash tools/test_freecad1.sh [RUNS]   (default 1; RUNS > 1 repeats the whole test command,
# which is how a race shows). Exit status: 0 when every run passed, else that of the last failing run.
set -uo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
cd "$here"
chroot_tool=${HULLPROD_DEBIAN13_CHROOT:-$here/../shared/tools/debian13-chroot.sh}
[ -x "$chroot_tool" ] || { echo "test_freecad1: $chroot_tool not found (set HULLPROD_DEBIAN13_CHROOT)"; exit 2; }
runs=${1:-1}
status=0
for run in $(seq 1 "$runs"); do
  start=$(date +%s)
  "$chroot_tool" 'bash tools/install.sh && ./hullprod example && bash tools/install.sh && bash tools/run_tests.sh'
  rc=$?
  echo "test_freecad1: run $run of $runs: exit $rc in $(( $(date +%s) - start )) s"
  [ "$rc" -eq 0 ] || status=$rc
done
exit "$status"
