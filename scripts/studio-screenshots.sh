#!/usr/bin/env bash
# Runs the README's scripted studio session under Xvfb and writes its screenshots to OUT
# (default docs/images): scripts/studio-screenshots.sh [BUILD_DIR] [OUT]
set -euo pipefail
BUILD=${1:-build}
OUT=${2:-docs/images}
mkdir -p "$OUT"
OUT_ABS=$(cd "$OUT" && pwd)
SCRIPT=$(mktemp --suffix=.json)
sed "s|\$OUT|$OUT_ABS|g" resources/studio/readme_session.json > "$SCRIPT"
# The app's own status (xvfb-run may return its own, e.g. 5 when its temporary folder races).
STATUS=$(mktemp)
xvfb-run -a -s "-screen 0 1280x800x24" sh -c '"$0" --script "$1"; echo $? > "$2"' \
  "$BUILD/app/btfstudio" "$SCRIPT" "$STATUS" || true
rc=$(cat "$STATUS")
rm -f "$STATUS"
if [ "$rc" != "0" ]; then
  echo "studio-screenshots: the scripted session failed (status ${rc:-unknown})" >&2
  exit 1
fi
rm -f "$SCRIPT" "$OUT_ABS"/brick.btf "$OUT_ABS"/brick.cbtf
rm -rf "$OUT_ABS"/brick-study
echo "screenshots in $OUT"
