#!/usr/bin/env bash
# The figures of docs/mip.md: brick on the hilly surface at a distance where a pixel covers ~16
# texels — point sampling at 1 sample per pixel, the MIP render at 1 sample per pixel, the
# 64-sample supersampled render of level 0, and the levels in false colour.
# Usage: scripts/mip-figures.sh [BUILD_DIR] [WORK_DIR]   (writes docs/images/mip_*.png)
set -euo pipefail
BUILD=${1:-build}
WORK=${2:-/tmp/btf-mip-figures}
ROOT=$(pwd)
B=$(realpath "$BUILD")/app/btfsim
mkdir -p "$WORK"
BTF=$WORK/brick.btf
[ -f "$BTF" ] || "$B" simulate resources/scenes/brick.json --texels 32 --dirs 8x16 -o "$BTF" -q
common=(--object plane --mode flat --tiling 48 --size 320x200 --projection perspective --camera 72,-90 --zoom 2.2 --light 45,-30 --exposure 2 -q)
"$B" render "$BTF" -o "$ROOT/docs/images/mip_point.png" --filter point --spp 1 "${common[@]}"
"$B" render "$BTF" -o "$ROOT/docs/images/mip_filtered.png" --filter mip --spp 1 "${common[@]}"
"$B" render "$BTF" -o "$ROOT/docs/images/mip_reference.png" --filter point --spp 64 "${common[@]}"
"$B" render "$BTF" -o "$ROOT/docs/images/mip_levels.png" --show-level --spp 1 "${common[@]}"
echo "wrote docs/images/mip_{point,filtered,reference,levels}.png"
