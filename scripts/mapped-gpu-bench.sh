#!/usr/bin/env bash
# The studio's mapped view on the GPU (docs/render.md, docs/performance.md "Objects on the GPU"):
# brick 32² × (6×16a)² compressed nmf 1:20 with its raw store (the visibility map), the
# Objects panel at render scale 0.5 — the flat and the mapped pass on the sphere and the vase
# (three runs, after the shader cache is warm), the GLSL march against the CPU renderer at
# 160×120 (time and pixel agreement), and UI frames while a mapped pass runs, alone and beside an
# exact CPU render. Mesa's llvmpipe under Xvfb: no GPU on these machines.
# Usage: scripts/mapped-gpu-bench.sh [BUILD_DIR] [WORK_DIR]
set -euo pipefail
BUILD=$(realpath "${1:-build}")
WORK=${2:-/tmp/btf-mapped-gpu-bench}
SCENE=$(realpath resources/scenes/brick.json)
mkdir -p "$WORK" && cd "$WORK"
B=$BUILD/app/btfsim
S=$BUILD/app/btfstudio
echo "## machine: $(nproc) cores, $(free -g | awk '/Mem:/{print $2}') GB; $(date -u +%F)"
[ -f brick.btf ] || $B simulate "$SCENE" --texels 32 --dirs 6x16a -o brick.btf --quiet
[ -f brick.cbtf ] || $B compress brick.btf -o brick.cbtf --codec nmf --target-ratio 20 --quiet
studio() { xvfb-run -a -s "-screen 0 1280x800x24" "$S" --script "$1" > "$1.log" 2>&1; }
for run in 1 2 3; do
  for obj in sphere vase; do
    python3 - "$WORK" "$obj" "$run" <<'PY'
import json, sys
w, obj, run = sys.argv[1:4]
a = [{"open_compressed": f"{w}/brick.cbtf", "reference": f"{w}/brick.btf"},
     {"layout": ["Objects"]},
     {"object": obj, "view": "flat", "tiling": 4},
     {"object": obj, "view": "flat", "light_theta": 50 + int(run)},
     {"object": obj, "view": "mapped"},
     {"object": obj, "view": "mapped", "light_theta": 40 + int(run)},
     {"check_mapped": {"size": [160, 120]}},
     {"object": obj, "view": "mapped", "light_theta": 30, "wait": 0},
     {"measure_frames": 1.5},
     {"report": f"{w}/{obj}{run}.json"}]
json.dump(a, open(f"{w}/{obj}{run}.script.json", "w"))
PY
    studio "$WORK/$obj$run.script.json"
  done
done
python3 - "$WORK" <<'PY'
import json, statistics, sys
w = sys.argv[1]
print("| object | flat pass (ms) | mapped pass (ms) | bands | GLSL march 160×120 vs CPU (ms) | pixels apart > 1 % of peak | UI frames during a mapped pass: median / p95 (ms) |")
print("|---|---|---|---|---|---|---|")
for obj in ("sphere", "vase"):
    rs = [json.load(open(f"{w}/{obj}{k}.json")) for k in (1, 2, 3)]
    med = lambda f: statistics.median(f(r) for r in rs)
    c = rs[-1]["check_mapped"]
    print(f"| {obj} | {med(lambda r: r['object_pass_ms']):.0f} | {med(lambda r: r['object_pass_ms_mapped']):.0f} | "
          f"{rs[-1]['object_pass_bands']} | {med(lambda r: r['check_mapped']['gpu_ms']):.0f} vs "
          f"{med(lambda r: r['check_mapped']['cpu_ms']):.1f} | {c['differing_pixels']} of {c['covered_pixels_both']} | "
          f"{med(lambda r: r['frames']['median_ms']):.1f} / {med(lambda r: r['frames']['p95_ms']):.1f} |")
PY
