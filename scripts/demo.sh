#!/usr/bin/env bash
# `make demo`: simulate the default scene (resources/scenes/brick.json) into out/, print the
# summary, write slice images and the averaged BRDF, and say where everything is.
set -euo pipefail
BUILD=${1:-build}
SIM="$BUILD/app/btfsim"
SCENE=resources/scenes/brick.json
mkdir -p out
echo "== simulate $SCENE (32x32 texels, bonn81 directions: 81 x 81 pairs)"
"$SIM" simulate "$SCENE" -o out/brick.btf --json > out/brick.summary.json
cat out/brick.summary.json
echo "== info"
"$SIM" info out/brick.btf
echo "== slices"
"$SIM" slice out/brick.btf --view 0,0 --light 45,0 -o out/brick_v0_l45.png
"$SIM" slice out/brick.btf --view 0,0 --light 75,90 -o out/brick_v0_l75.png
"$SIM" slice out/brick.btf --view 60,180 --light 60,0 -o out/brick_v60_l60.png
"$SIM" slice out/brick.btf --view 30,0 --light 45,0 -o out/brick_v30_l45.exr
"$SIM" slice out/brick.btf --texel avg --light 45,0 -o out/brick_brdf_l45.png
"$SIM" slice out/brick.btf --texel 8,8 --light 45,0 -o out/brick_texel8_8_l45.png
echo "== averaged BRDF (texel average, 128x128 rays per pair, exact shadow rays)"
"$SIM" brdf "$SCENE" --spp 128 \
  --pair 0,0,0,0 --pair 30,0,30,180 --pair 45,0,45,180 --pair 60,0,60,180 --pair 75,0,75,180 \
  --pair 45,0,45,0 --pair 45,90,45,270 --pair 80,0,10,0 > out/brick_brdf.csv
cat out/brick_brdf.csv
echo
echo "Outputs are in $(pwd)/out:"
ls -1 out | sed 's/^/  out\//'
