#!/bin/bash
# The README's two commands on FreeCAD 1.x in a chroot, each run in a fresh clone of this
# repository's committed HEAD:
#   1.0: Debian 13 (FreeCAD 1.0.0, OpenCascade 7.8, Python 3.13, numpy 2), ../shared/tools/debian13-chroot.sh
#   1.1: Debian testing (FreeCAD 1.1, Qt 6, OpenCascade 7.9, Python 3.14, numpy 2.4), ../shared/tools/freecad11-chroot.sh
# The chroot tool builds its chroot the first time (as root: a few minutes and about 2.6 GB).
# Usage: bash tools/test_freecad1.sh [1.0|1.1] [RUNS]   (default 1.0 and 1 run; RUNS > 1 repeats the
# whole test command, which is how a race shows). Exit status: 0 when every run passed, else that
# of the last failing run; 2 when the chroot tool is not there.
set -uo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
cd "$here"
version=1.0
case ${1:-} in 1.0|1.1) version=$1; shift ;; esac
case $version in
  1.0) chroot_tool=${HULLPROD_DEBIAN13_CHROOT:-$here/../shared/tools/debian13-chroot.sh} ;;
  1.1) chroot_tool=${HULLPROD_FREECAD11_CHROOT:-$here/../shared/tools/freecad11-chroot.sh} ;;
esac
[ -x "$chroot_tool" ] || { echo "test_freecad1: FreeCAD $version: $chroot_tool not found"; exit 2; }
runs=${1:-1}
status=0
for run in $(seq 1 "$runs"); do
  start=$(date +%s)
  "$chroot_tool" 'bash tools/install.sh && ./hullprod example && bash tools/install.sh && bash tools/run_tests.sh'
  rc=$?
  echo "test_freecad1: FreeCAD $version: run $run of $runs: exit $rc in $(( $(date +%s) - start )) s"
  [ "$rc" -eq 0 ] || status=$rc
done
exit "$status"
