#!/bin/bash
# Run the whole test suite (or the tests named in the arguments) headless with Debian's Python and FreeCAD's modules.
# GUI tests start the real FreeCAD under Xvfb themselves.
set -uo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
cd "$here"
export QT_QPA_PLATFORM=${QT_QPA_PLATFORM:-offscreen}
# One BLAS thread, as the command runs (./hullprod): a process with no thread besides its
# own may fork worker and reading processes (core.processes.fork_is_clean).
export OPENBLAS_NUM_THREADS="${OPENBLAS_NUM_THREADS:-1}" OMP_NUM_THREADS="${OMP_NUM_THREADS:-1}"
# Test files or test ids among the arguments: those alone; otherwise the whole folder.
targets=tests
for a in "$@"; do case $a in tests/*|*.py|*::*) targets= ;; esac; done
/usr/bin/python3 -m pytest $targets -p no:cacheprovider -q -ra "$@"
