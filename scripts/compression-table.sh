#!/usr/bin/env bash
# The compression table of docs/performance.md (like the thesis's table 3.II): for each scene,
# simulate a raw BTF, then compress it with every codec at a target ratio and at the default
# error target, measuring ratio, RMSE, relative RMSE, PSNR, time and peak memory.
# Usage: scripts/compression-table.sh [BUILD_DIR] [TEXELS] [DIRS] [OUT_DIR]
set -euo pipefail
BUILD=${1:-build}
TEXELS=${2:-32}
DIRS=${3:-16x32}
OUT=${4:-out/compression-table}
B="$BUILD/app/btfsim"
mkdir -p "$OUT"
TABLE="$OUT/table.md"
echo "| scene | codec | target | raw | compressed | ratio | RMSE | rel. RMSE | PSNR | time | peak RSS |" > "$TABLE"
echo "|---|---|---|---|---|---|---|---|---|---|---|" >> "$TABLE"
for scene in brick weave leather bumps; do
  raw="$OUT/$scene.btf"
  "$B" simulate "resources/scenes/$scene.json" -o "$raw" --texels "$TEXELS" --dirs "$DIRS" --spp 2 -q > "$OUT/$scene.sim.txt"
  for codec in nmf svd perview lpca; do
    for target in "--target-ratio 300" "--target-rmse 0.05"; do
      tag=$(echo "$target" | tr -d ' -')
      "$B" compress "$raw" -o "$OUT/$scene.$codec.$tag.cbtf" --codec "$codec" $target --compare --json -q \
        > "$OUT/$scene.$codec.$tag.json"
      python3 - "$OUT/$scene.$codec.$tag.json" "$scene" "$codec" "$target" >> "$TABLE" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
e = j["error"]
mib = lambda b: "%.1f MiB" % (b / 2**20) if b < 2**30 else "%.2f GiB" % (b / 2**30)
print("| %s | %s | %s | %s | %s | 1:%.0f | %.4f | %.2f %% | %.1f dB | %.1f s | %s |" % (
    sys.argv[2], sys.argv[3], sys.argv[4].replace("--", ""), mib(j["raw_bytes"]),
    mib(j["compressed_bytes"]), j["ratio"], e["rmse"], 100 * e["relative_rmse"], e["psnr_db"],
    j["seconds"], mib(j["peak_memory_bytes"])))
PY
      rm -f "$OUT/$scene.$codec.$tag.cbtf"
    done
  done
  rm -f "$raw"
done
cat "$TABLE"
