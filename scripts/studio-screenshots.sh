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
xvfb-run -a -s "-screen 0 1280x800x24" "$BUILD/app/btfstudio" --script "$SCRIPT"
rm -f "$SCRIPT" "$OUT_ABS"/brick.btf "$OUT_ABS"/brick.cbtf
rm -rf "$OUT_ABS"/brick-study
echo "screenshots in $OUT"
