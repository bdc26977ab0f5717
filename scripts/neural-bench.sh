#!/bin/bash
# The neural codec against the tensor and nmf codecs (docs/compression.md, "neural"): weave,
# leather and brick at 32² × bonn81, uniform 8×8 references (their noise floor from a second
# seed), per-value relative RMSE and the worst texel, compress time and ratio. 2 cores, one run
# each (~25 min).   bash scripts/neural-bench.sh   (writes into /tmp/nb)
cd "$(dirname "$0")/.." && mkdir -p /tmp/nb
B=build/app/btfsim
T() { local s=$(date +%s.%N); "$@" -q > /dev/null 2>&1 || echo "FAILED: $*"; echo "$(echo "$(date +%s.%N) - $s" | bc)"; }
E() { $B compare "$1" "$2" -q --json | python3 -c 'import json,sys; j=json.load(sys.stdin); print("rel %.2f %%  worst texel rmse/ref rms %.2f" % (100*j["relative_rmse"], j["worst_texels"][0]["rmse"]/j["reference_rms"]))'; }
N() { $B compare "$1" "$2" -q --json | python3 -c 'import json,sys,math; j=json.load(sys.stdin); print("rel %.2f %%" % (100*j["relative_rmse"]/math.sqrt(2)))'; }
R() { python3 -c "import os; print('1:%.0f' % ($(stat -c %s "$1") / $(stat -c %s "$2")))"; }
for sc in ${SCENES:-weave leather brick}; do
  S=resources/scenes/$sc.json; C="--texels 32 --dirs bonn81 --sampling uniform --spp 8"
  R8=/tmp/nb/${sc}8.btf
  [ -f $R8 ] || echo "$sc simulate $(T $B simulate $S -o $R8 $C) s"
  [ -f /tmp/nb/${sc}8b.btf ] || T $B simulate $S -o /tmp/nb/${sc}8b.btf $C --seed 2 > /dev/null
  echo "== $sc  noise floor (two seeds, /√2): $(N $R8 /tmp/nb/${sc}8b.btf)"
  while read -r name args; do
    out=/tmp/nb/${sc}_$name.cbtf
    t=$(T $B compress $R8 -o $out $args)
    echo "$name: $(E $R8 $out)  ratio $(R $R8 $out)  ${t} s"
  done <<'LIST'
nmf300 --codec nmf --target-ratio 300
tensor300 --codec tensor --target-ratio 300
tensor1000 --codec tensor --target-ratio 1000
neural --codec neural
neural16x64 --codec neural --components 16 --hidden 64 --neural-steps 8000
LIST
done
