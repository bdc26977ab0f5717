#!/bin/bash
# Exact direct light by area against uniform sampling (docs/accuracy.md "Exact direct light by
# area"): brick and V-grooves, 32² × bonn81, direct light only; times and per-value errors
# against uniform 32 × 32 with shadow rays. 2 cores, one run each (~12 min).
#   bash scripts/exact-visibility-bench.sh   (writes into /tmp/m)
cd "$(dirname "$0")/.." && mkdir -p /tmp/m
B=build/app/btfsim
T() { local s=$(date +%s.%N); "$@" -q > /dev/null 2>&1 || echo "FAILED: $*"; echo "$(echo "$(date +%s.%N) - $s" | bc)"; }
for sc in brick vgrooves; do
  S=resources/scenes/$sc.json; C="--texels 32 --dirs bonn81 --interreflection off"
  echo "== $sc direct only"
  echo "u32 $(T $B simulate $S -o /tmp/m/${sc}_u32.btf $C --sampling uniform --spp 32 --shadows rays)"
  echo "u16 $(T $B simulate $S -o /tmp/m/${sc}_u16.btf $C --sampling uniform --spp 16 --shadows rays)"
  echo "u16b $(T $B simulate $S -o /tmp/m/${sc}_u16b.btf $C --sampling uniform --spp 16 --shadows rays --seed 2)"
  echo "u2 $(T $B simulate $S -o /tmp/m/${sc}_u2.btf $C --sampling uniform --spp 2)"
  echo "ad $(T $B simulate $S -o /tmp/m/${sc}_ad.btf $C --visibility sampled)"
  echo "ex $(T $B simulate $S -o /tmp/m/${sc}_ex.btf $C)"
  echo "ex2 $(T $B simulate $S -o /tmp/m/${sc}_ex2.btf $C)"
  for x in u16 u16b u2 ad ex; do echo "cmp u32 $x: $($B compare /tmp/m/${sc}_u32.btf /tmp/m/${sc}_$x.btf -q --json | python3 -c 'import json,sys; j=json.load(sys.stdin); print("rel %.4f %%  max_abs %.4g  worst texel rmse %.4g  ref rms %.4g" % (100*j["relative_rmse"], j["max_abs_error"], j["worst_texels"][0]["rmse"], j["reference_rms"]))')"; done
  echo "cmp u16 u16b: $($B compare /tmp/m/${sc}_u16.btf /tmp/m/${sc}_u16b.btf -q --json | python3 -c 'import json,sys; j=json.load(sys.stdin); print("rel %.4f %%" % (100*j["relative_rmse"]))')"
done
