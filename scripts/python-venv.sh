#!/usr/bin/env bash
# The project's Python virtual environment for the Mitsuba 3 plugin (docs/python.md):
# BUILD/venv over the system Python (Debian's numpy and pytest stay visible), the pinned
# packages of python/requirements-mitsuba.txt from PyPI, and a .pth that puts BUILD/python (the
# btfstudio package) on its path. Idempotent: nothing is fetched when the pins are installed.
set -euo pipefail
BUILD=${1:-build}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
REQ="$ROOT/python/requirements-mitsuba.txt"
VENV="$BUILD/venv"
PY=/usr/bin/python3
[ -x "$PY" ] || PY=$(command -v python3)
if [ ! -x "$VENV/bin/python" ]; then
  "$PY" -m venv --system-site-packages "$VENV"
fi
BUILD_ABS=$(cd "$BUILD" && pwd)
SITE=$("$VENV/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
echo "$BUILD_ABS/python" > "$SITE/btfstudio-build.pth"
STAMP="$VENV/.requirements"
if [ -f "$STAMP" ] && cmp -s "$STAMP" "$REQ"; then exit 0; fi
echo "python-venv: installing $(grep -v '^#' "$REQ" | tr '\n' ' ')into $VENV" >&2
"$VENV/bin/python" -m pip install --disable-pip-version-check -q -r "$REQ"
cp "$REQ" "$STAMP"
