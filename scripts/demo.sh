#!/usr/bin/env bash
# `make demo`: simulate the default scene (resources/scenes/brick.json) into out/ with the effects
# its plan calls for (direct light, self-shadowing, inter-reflection by the point network), print
# the plan and the summary, write slice images and the averaged BRDF, render it on the vase
# (exact, mapped and flat side by side), compress it (and stream a
# simulation straight into the compressor), export to UBO2014 and MERL, rerun the simulation on 2
# MPI ranks (when Open MPI is installed), run a small accuracy-vs-time study against the path
# tracer, and say where everything is.
set -euo pipefail
BUILD=${1:-build}
SIM="$BUILD/app/btfsim"
SCENE=resources/scenes/brick.json
mkdir -p out
echo "== effect plan of $SCENE"
"$SIM" plan "$SCENE"
echo "== simulate $SCENE (32x32 texels, 6x16a directions: 81 x 81 pairs, direct light exact by area (every face flat), GI by the point network)"
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
echo "== averaged BRDF (texel average, 128x128 path-traced positions per pair, every effect)"
"$SIM" brdf "$SCENE" --spp 128 \
  --pair 0,0,0,0 --pair 30,0,30,180 --pair 45,0,45,180 --pair 60,0,60,180 --pair 75,0,75,180 \
  --pair 45,0,45,0 --pair 45,90,45,270 --pair 80,0,10,0 > out/brick_brdf.csv
cat out/brick_brdf.csv
echo "== compress at 1:300: clustered tensor (thesis §4.4.2) and per-texel NMF + PCA (§3.4)"
"$SIM" compress out/brick.btf -o out/brick.cbtf --codec tensor --target-ratio 300 --compare
"$SIM" compress out/brick.btf -o out/brick_nmf.cbtf --codec nmf --target-ratio 300 --compare
"$SIM" compare out/brick.btf out/brick.cbtf --maps out/brick_compression_error --worst 3
echo "== export (UBO2014 within 1 % of the compressed BTF; MERL, symmetrised)"
"$SIM" export out/brick.cbtf --format ubo2014 -o out/brick_dfmf.btf
"$SIM" export out/brick.cbtf --format merl -o out/brick_merl.binary
echo "== brick on the vase (docs/render.md): exact micro-geometry | mapped shell (silhouettes from the VMF) | flat"
"$SIM" render out/brick.btf -o out/brick_vase.png --mode all --object vase --size 256 --spp 8 --tiling 6 --camera 25,-80 --light 40,-40 --exposure 1.6
echo "== simulate and compress in one stream (no raw BTF on disk)"
"$SIM" simulate "$SCENE" -o out/brick_streamed.cbtf --compress tensor --target-ratio 300 -q
echo "== the streamed .cbtf on the sphere, alone (it carries its visibility map: no raw store)"
"$SIM" render out/brick_streamed.cbtf -o out/brick_streamed_sphere.png --object sphere --size 192 --spp 4
if command -v mpirun > /dev/null; then
  echo "== the same simulation as one job of 2 MPI ranks (docs/cluster.md): the same bytes"
  # mpirun refuses root unless told (containers, CI).
  OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 mpirun --oversubscribe -np 2 \
    "$SIM" simulate "$SCENE" -o out/brick_mpi.btf -q
  cmp out/brick.btf out/brick_mpi.btf && echo "out/brick_mpi.btf is byte-identical to out/brick.btf"
fi
echo "== accuracy vs time (small study: 16x16 texels, against the path tracer)"
"$SIM" study "$SCENE" -o out/study --texels 16 --method network,pt --dirs bonn81,8x16 --spp 1,2 \
  --shadows map --network-voxels 0 --gather 4 --links 16 --bounces 3,1,2 --reference-spp 128 -q
echo
echo "Outputs are in $(pwd)/out:"
ls -1 out | sed 's/^/  out\//'
echo
echo "== the desktop app"
if [ -n "${DISPLAY:-}${WAYLAND_DISPLAY:-}" ]; then
  echo "Open it on this scene:  make studio   (or: $BUILD/app/btfstudio $SCENE)"
else
  echo "No display here: a scripted studio session under Xvfb writes its screenshots to out/studio/"
  bash scripts/studio-screenshots.sh "$BUILD" out/studio
  echo "On a machine with a display, open the app with:  make studio"
fi
