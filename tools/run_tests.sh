#!/bin/bash
# Run the whole test suite headless with Debian's Python and FreeCAD's modules.
# GUI tests start the real FreeCAD under Xvfb themselves.
set -uo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
cd "$here"
export QT_QPA_PLATFORM=${QT_QPA_PLATFORM:-offscreen}
/usr/bin/python3 -m pytest tests -p no:cacheprovider -q -ra "$@"
