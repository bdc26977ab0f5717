#!/usr/bin/env bash
# Multi-resolution BTFs (docs/mip.md), the figures of docs/performance.md "Texel levels":
#  1. the pyramid's size and per-level error against a single-level file of the same codec;
#  2. building the levels against the base simulation's time;
#  3. renders at 1 sample per pixel (point: level 0 only; mip: footprint levels) against a
#     64-sample supersampled render of level 0, where one pixel covers 4-16 texels.
# Usage: scripts/mip-bench.sh [BUILD_DIR] [WORK_DIR]
set -euo pipefail
BUILD=${1:-build}
WORK=${2:-/tmp/btf-mip-bench}
B=$(realpath "$BUILD")/app/btfsim
SCENE=$(realpath resources/scenes/brick.json)
mkdir -p "$WORK" && cd "$WORK"
field() { python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))[sys.argv[2]])' "$1" "$2"; }

echo "## machine: $(nproc) cores, $(free -g | awk '/Mem:/{print $2}') GB; $(date -u +%F)"
$B simulate "$SCENE" --texels 32 --dirs 8x16 -o brick.btf --quiet --json > sim.json
SIM=$(field sim.json wall_seconds)
echo "simulate brick 32² × (8×16)² (default adaptive sampling): $SIM s"

echo
echo "| file | codec target | bytes | vs single | level errors (relative RMSE, %) | levels built |"
echo "|---|---|---|---|---|---|"
$B compress brick.btf -o single.cbtf --codec tensor --target-ratio 300 --compare --quiet --json > single.json
S=$(field single.json compressed_bytes)
echo "| single level | 1:300 | $S | 1.00× | $(python3 -c "import json; print('%.2f' % (100*json.load(open('single.json'))['error']['relative_rmse']))") | – |"
for R in 300 350 400; do
  $B compress brick.btf -o mip$R.cbtf --codec tensor --target-ratio $R --mip --quiet --json > mip$R.json
  python3 - "$R" "$S" "$SIM" <<'PY'
import json, sys
r, s, sim = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
d = json.load(open(f"mip{r}.json"))
errs = " / ".join("%.2f" % (100 * l["relative_rmse"]) for l in d["levels"])
print(f"| pyramid, {len(d['levels'])} levels | 1:{r} of the pyramid | {d['compressed_bytes']} | "
      f"{d['compressed_bytes'] / s:.2f}× | {errs} | {d['level_seconds']:.2f} s "
      f"({100 * d['level_seconds'] / sim:.1f} % of the simulation) |")
PY
done

echo
echo "Relative RMSE against the 64-sample render of level 0: all covered pixels | the pixels both cover fully (no silhouette)."
echo
echo "| object | tiling | texels per pixel | mode | point, 1 spp | point, interior | mip, 1 spp | mip, interior | 64-spp floor | mip time / 64-spp time |"
echo "|---|---|---|---|---|---|---|---|---|---|"
for OBJ in plane hills; do
  for T in 5 8 10; do
    for MODE in flat mapped; do
      common=(--object "$OBJ" --mode "$MODE" --tiling "$T" --size 128 --quiet --json)
      $B render brick.btf -o ref.exr --filter point --spp 64 "${common[@]}" > ref.json
      $B render brick.btf -o ref2.exr --filter point --spp 64 --seed 7 --reference ref.exr "${common[@]}" > ref2.json
      $B render brick.btf -o p.exr --filter point --spp 1 --reference ref.exr "${common[@]}" > p.json
      $B render brick.btf -o m.exr --filter mip --spp 1 --reference ref.exr "${common[@]}" > m.json
      python3 - "$OBJ" "$T" "$MODE" <<'PY'
import json, sys
obj, t, mode = sys.argv[1:]
img = lambda f: json.load(open(f))["images"][0]
ref, ref2, p, m = img("ref.json"), img("ref2.json"), img("p.json"), img("m.json")
tex = p["footprint"]["median_texels_per_sample"]
floor = ref2["error"]["rel_rmse"] / 2 ** 0.5
e = lambda i: "%.2f %% | %.2f %%" % (100 * i["error"]["rel_rmse"], 100 * i["error"]["rel_rmse_interior"])
print(f"| {obj} | {t} | {tex:.1f} | {mode} | {e(p)} | {e(m)} | {100 * floor:.2f} % | "
      f"{m['seconds']:.3f} s / {ref['seconds']:.3f} s |")
PY
    done
  done
done
