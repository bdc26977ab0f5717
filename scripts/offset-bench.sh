#!/bin/bash
# Between set directions (issue 37, target 3): a file trained at bonn81 measured against a
# simulation at another set, 6x12 (θ cell centres 7.5°..82.5°, none of bonn81's directions),
# and against its own set; the neural codec (its own continuous decode) beside tensor
# (interpolation between set directions). Uniform 8×8 references, noise floors from a second
# seed. 2 cores: ~8 min.   SCENES="weave brick" bash scripts/offset-bench.sh   (into /tmp/nb)
cd "$(dirname "$0")/.." && mkdir -p /tmp/nb
B=build/app/btfsim
E() { $B compare "$1" "$2" -q --json | python3 -c 'import json,sys; j=json.load(sys.stdin); print("%.2f %% (worst texel %.2f)" % (100*j["relative_rmse"], j["worst_texels"][0]["rmse"]/j["reference_rms"]))'; }
N() { $B compare "$1" "$2" -q --json | python3 -c 'import json,sys,math; j=json.load(sys.stdin); print("%.2f %%" % (100*j["relative_rmse"]/math.sqrt(2)))'; }
for sc in ${SCENES:-weave}; do
  S=resources/scenes/$sc.json; C="--texels 32 --sampling uniform --spp 8"
  for set in bonn81 6x12; do
    [ -f /tmp/nb/${sc}8_$set.btf ] || $B simulate $S -o /tmp/nb/${sc}8_$set.btf --dirs $set $C -q
    [ -f /tmp/nb/${sc}8b_$set.btf ] || $B simulate $S -o /tmp/nb/${sc}8b_$set.btf --dirs $set $C --seed 2 -q
    echo "== $sc $set noise floor: $(N /tmp/nb/${sc}8_$set.btf /tmp/nb/${sc}8b_$set.btf)"
  done
  while read -r name args; do
    out=/tmp/nb/${sc}_off_$name.cbtf
    [ -f $out ] || $B compress /tmp/nb/${sc}8_bonn81.btf -o $out $args -q
    echo "$sc $name: at bonn81 $(E /tmp/nb/${sc}8_bonn81.btf $out); at 6x12 $(E /tmp/nb/${sc}8_6x12.btf $out)"
  done <<'LIST'
tensor300 --codec tensor --target-ratio 300
neural --codec neural
neural16x64 --codec neural --components 16 --hidden 64 --neural-steps 8000
LIST
done
