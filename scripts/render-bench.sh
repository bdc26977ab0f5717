#!/usr/bin/env bash
# The object renderer's targets (docs/render.md, docs/performance.md): spheres on the curved
# section and brick on the vase at SIZE² (default 512), mapped and flat against a converged exact
# image, with the reference's own noise floor, and the exact image's time to reach the mapped
# image's error. Writes out/render-bench/table.md (and the images beside it).
#   bash scripts/render-bench.sh [BUILD_DIR] [SIZE] [TEXELS] [DIRS] [TILINGS]
set -euo pipefail
BUILD=${1:-build}
SIZE=${2:-512}
TEXELS=${3:-64}
DIRS=${4:-8x16a}
TILINGS=${5:-"4 12"}
SIM="$BUILD/app/btfsim"
OUT=out/render-bench
mkdir -p "$OUT"
TABLE="$OUT/table.md"
REF_SPP=${REF_SPP:-256}
err() { python3 -c 'import json,sys; j=json.load(sys.stdin); i=j["images"][0]; e=i.get("error",{}); print(i["seconds"], e.get("rel_rmse",0), e.get("coverage_mismatch",0))'; }
{
  echo "| scene on object | tiling | BTF | mode | spp | seconds | rel. RMSE | coverage mismatch |"
  echo "|---|---|---|---|---|---|---|---|"
} > "$TABLE"
for pair in spheres:section brick:vase; do
  scene=${pair%%:*}
  object=${pair##*:}
  btf="$OUT/$scene-$TEXELS-$DIRS.btf"
  if [ ! -f "$btf" ]; then
    echo "== simulate $scene at ${TEXELS}² texels, $DIRS directions"
    "$SIM" simulate "resources/scenes/$scene.json" -o "$btf" --texels "$TEXELS" --dirs "$DIRS" -q
  fi
  for T in $TILINGS; do
    base="$OUT/$scene-$object-t$T"
    common=(--object "$object" --size "$SIZE" --tiling "$T" -q --json)
    echo "== $scene on $object, tiling $T: exact reference at $REF_SPP spp"
    "$SIM" render "$btf" -o "$base.ref.exr" --mode exact --spp "$REF_SPP" --seed 101 "${common[@]}" > /dev/null
    # The reference's noise floor: a second reference with another seed.
    read -r _ e _ < <("$SIM" render "$btf" -o "$base.ref2.exr" --mode exact --spp "$REF_SPP" --seed 202 \
      --reference "$base.ref.exr" "${common[@]}" | err)
    floor=$(python3 -c "print(f'{$e/2**0.5*100:.2f} %')")
    echo "   reference noise floor (two seeds, RMS difference / √2): $floor"
    for mode in mapped flat; do
      read -r s e c < <("$SIM" render "$btf" -o "$base.$mode.exr" --mode "$mode" --spp 16 \
        --reference "$base.ref.exr" "${common[@]}" | err)
      printf '| %s on %s | %s | %s² %s | %s | 16 | %.2f | %.2f %% | %.2f %% |\n' "$scene" "$object" "$T" \
        "$TEXELS" "$DIRS" "$mode" "$s" "$(python3 -c "print($e*100)")" "$(python3 -c "print($c*100)")" >> "$TABLE"
      [ "$mode" = mapped ] && mappedErr=$e && mappedSec=$s
    done
    for spp in 1 2 4 8 16 32 64; do
      read -r s e c < <("$SIM" render "$btf" -o "$base.exact$spp.exr" --mode exact --spp "$spp" \
        --seed 303 --reference "$base.ref.exr" "${common[@]}" | err)
      printf '| %s on %s | %s | (scene) | exact | %s | %.2f | %.2f %% | %.2f %% |\n' "$scene" "$object" "$T" \
        "$spp" "$s" "$(python3 -c "print($e*100)")" "$(python3 -c "print($c*100)")" >> "$TABLE"
      if python3 -c "import sys; sys.exit(0 if $e <= $mappedErr else 1)"; then
        echo "   exact reaches the mapped error ($(python3 -c "print(f'{$mappedErr*100:.1f}')") %) at $spp spp in $s s; mapped took $mappedSec s"
        break
      fi
    done
    echo "| $scene on $object | $T | | reference noise floor ($REF_SPP spp) | | | $floor | |" >> "$TABLE"
  done
done
echo
cat "$TABLE"
