#!/usr/bin/env bash
# Cluster benchmark (docs/cluster.md, docs/performance.md): one threaded process against
# `mpirun -np 2` (one thread per rank) and `mpirun -np 3 --oversubscribe` on this machine, for
# simulate, simulate --compress and compress; median wall time of REPS runs, the files compared
# byte for byte, and each rank's communicated bytes from the --json report.
#   scripts/cluster-bench.sh [BUILD_DIR] [SCENE] [TEXELS] [REPS]
set -euo pipefail
BUILD=${1:-build}
SCENE=${2:-resources/scenes/brick.json}
TEXELS=${3:-48}
REPS=${4:-3}
BTFSIM=$(realpath "$BUILD/app/btfsim")
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
median() { sort -g | awk '{a[NR]=$1} END {print a[int((NR + 1) / 2)]}'; }
wall() { python3 -c "import json,sys; j=json.load(open(sys.argv[1])); print(j.get('wall_seconds', j.get('seconds')))" "$1"; }
comm() { python3 -c "
import json,sys; j=json.load(open(sys.argv[1])); c=j.get('cluster')
print('-' if not c else '%.3f %% (max %s bytes)' % (100*c['max_communicated_fraction'], int(c['max_communicated_bytes'])))" "$1"; }
run() {  # run NAME LAUNCHER ARGS… : median wall of REPS runs, the last run's file kept
  local name=$1 launch=$2
  shift 2
  local times=()
  for _ in $(seq "$REPS"); do
    rm -f "$T/$name".*
    $launch "$BTFSIM" "$@" -q --json > "$T/$name.json"
    times+=("$(wall "$T/$name.json")")
  done
  printf '%s\n' "${times[@]}" | median
}
echo "machine: $(nproc) cores, $(free -g | awk '/Mem:/ {print $2}') GB; scene $SCENE, ${TEXELS}² texels, bonn81, median of $REPS"
printf '%-52s %10s %10s %10s  %s\n' "job" "1 proc" "np 2" "np 3" "communication (np 3, worst rank)"
for job in simulate stream compress; do
  case $job in
    simulate) args=(simulate "$SCENE" --texels "$TEXELS"); ext=btf ;;
    stream) args=(simulate "$SCENE" --texels "$TEXELS" --compress nmf --target-ratio 300); ext=cbtf ;;
    compress) args=(compress "$T/ref.btf" --codec tensor --target-ratio 300); ext=cbtf ;;
  esac
  [ "$job" = compress ] && [ ! -f "$T/ref.btf" ] && "$BTFSIM" simulate "$SCENE" --texels "$TEXELS" -o "$T/ref.btf" -q > /dev/null
  a=$(run "one" "" "${args[@]}" -o "$T/one.$ext")
  b=$(run "two" "mpirun -np 2" "${args[@]}" -o "$T/two.$ext")
  c=$(run "three" "mpirun --oversubscribe -np 3" "${args[@]}" -o "$T/three.$ext")
  same=$(cmp -s "$T/one.$ext" "$T/two.$ext" && cmp -s "$T/one.$ext" "$T/three.$ext" && echo identical || echo DIFFERENT)
  label="${args[*]}"
  label=${label//$T\//}
  label=${label//$SCENE/SCENE}
  printf '%-52s %9.2fs %9.2fs %9.2fs  %s; files %s\n' "$label" "$a" "$b" "$c" "$(comm "$T/three.json")" "$same"
done
