#!/bin/bash
# Install what HullProd needs on Debian 12 (run as root; safe to run again):
# Debian's FreeCAD, numpy, scipy, matplotlib, pytest, Xvfb, Dask; trimesh from PyPI for
# Debian's Python; the workbench linked into FreeCAD's user Mod folders and byte-compiled.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
PY=/usr/bin/python3
DEB_PACKAGES="freecad python3-numpy python3-scipy python3-matplotlib python3-pytest python3-pip
  python3-dask python3-distributed xvfb xauth"
TRIMESH_SPEC="trimesh>=4.4,<5"

sudo_() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }

missing=""
for p in $DEB_PACKAGES; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing="$missing $p"
done
if [ -n "$missing" ]; then
  echo "hullprod install: Debian packages:$missing" >&2
  sudo_ apt-get update -qq
  sudo_ env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $missing >/dev/null
fi

# trimesh for Debian's Python (FreeCAD's interpreter); --no-deps keeps Debian's numpy.
if ! $PY -c "import trimesh" 2>/dev/null; then
  echo "hullprod install: trimesh from PyPI for $PY" >&2
  sudo_ $PY -m pip install -q --break-system-packages --no-deps "$TRIMESH_SPEC"
fi

# Link the workbench into the user Mod folder of every installed FreeCAD, as each one
# reports it (FreeCAD.getUserAppDataDir(): FreeCAD 1.1 gives a fresh user v1-1/), and into
# the older unversioned Mod folders that already exist. A folder FreeCAD did not name is not
# created: its presence would change where FreeCAD 1.1 keeps the user's data.
mods=""
for cmd in freecadcmd FreeCADCmd freecadcmd-daily; do
  command -v "$cmd" >/dev/null || continue
  dir=$(cd "${TMPDIR:-/tmp}" && timeout 120 "$cmd" -c "import FreeCAD; print('HULLPROD_USERDIR=' + FreeCAD.getUserAppDataDir())" 2>/dev/null \
        | sed -n 's/^HULLPROD_USERDIR=//p' | tail -1)
  [ -n "$dir" ] && mods="$mods${dir%/}/Mod"$'\n'
done
[ -n "$mods" ] || mods="${XDG_DATA_HOME:-$HOME/.local/share}/FreeCAD/Mod"$'\n'
for legacy in "$HOME/.FreeCAD" "${XDG_DATA_HOME:-$HOME/.local/share}/FreeCAD"; do
  [ -d "$legacy/Mod" ] && mods="$mods$legacy/Mod"$'\n'
done
while IFS= read -r mod; do
  [ -n "$mod" ] || continue
  mkdir -p "$mod"
  ln -sfn "$here" "$mod/HullProd"
  echo "hullprod install: linked $mod/HullProd" >&2
done <<< "$(printf '%s' "$mods" | sort -u)"
# Byte-compile the package once, as pip does on install: commands then read the cached
# .pyc files instead of compiling every module (also where PYTHONDONTWRITEBYTECODE is set).
$PY -m compileall -q "$here/hullprod_wb"
$PY - <<PYEOF
import sys
sys.path.append('/usr/lib/freecad-python3/lib')
import FreeCAD, Part, numpy, scipy, trimesh
print("hullprod install: FreeCAD %s, OCC %s, numpy %s, scipy %s, trimesh %s; workbench linked from $here"
      % (".".join(FreeCAD.Version()[:3]), Part.OCC_VERSION, numpy.__version__, scipy.__version__,
         trimesh.__version__), file=sys.stderr)
PYEOF
