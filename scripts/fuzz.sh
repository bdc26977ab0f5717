#!/usr/bin/env bash
# Runs every libFuzzer target of the fuzz build for a bounded time (make fuzz; docs/reliability.md).
#   scripts/fuzz.sh BUILD_DIR SECONDS_PER_TARGET [TARGET...]
# Each target starts from its seed corpus (tests/fuzz/corpus/T) and its regression corpus
# (tests/fuzz/regressions/T), read only; what it learns goes to BUILD_DIR/fuzz-corpus/T and any
# finding (crash, timeout > 10 s, allocation > 1 GiB, RSS > 2 GiB) to BUILD_DIR/fuzz-findings/T/.
# Prints a table of executions, coverage and findings; exits 1 when there is a finding.
set -uo pipefail
BUILD=$(cd "${1:?build dir}" && pwd)
SECONDS_PER=${2:-60}
shift 2 || true
TARGETS=("$@")
[ ${#TARGETS[@]} -eq 0 ] && TARGETS=(scene mesh image btf cbtf pairs)
SRC=$(cd "$(dirname "$0")/.." && pwd)
JOBS=${FUZZ_JOBS:-$(nproc)}
SUMMARY="$BUILD/fuzz-summary.md"
echo "| target | seconds | workers | executions | exec/s | coverage (edges) | oom/timeout/crash | findings |" > "$SUMMARY"
echo "|---|---|---|---|---|---|---|---|" >> "$SUMMARY"
status=0
for t in "${TARGETS[@]}"; do
  bin="$BUILD/tests/fuzz/fuzz_$t"
  [ -x "$bin" ] || { echo "fuzz: $bin not built" >&2; exit 2; }
  corpus="$BUILD/fuzz-corpus/$t"
  findings="$BUILD/fuzz-findings/$t"
  logs="$BUILD/fuzz-logs/$t"
  rm -rf "$logs"
  mkdir -p "$corpus" "$findings" "$logs"
  echo "fuzz: $t for ${SECONDS_PER} s on $JOBS worker(s)" >&2
  # -fork keeps going past a finding so one bug does not hide the rest; each worker is a
  # separate process with its own limits.
  (cd "$logs" && ASAN_OPTIONS=detect_leaks=0:allocator_may_return_null=0 \
    UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
    "$bin" -fork="$JOBS" -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1 \
      -max_total_time="$SECONDS_PER" -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=1024 \
      -max_len=262144 -artifact_prefix="$findings/" -print_final_stats=1 \
      "$corpus" "$SRC/tests/fuzz/corpus/$t" "$SRC/tests/fuzz/regressions/$t" > "$logs/fuzz.log" 2>&1)
  # Fork mode's status lines: "#EXECS: cov: C ft: F corp: N exec/s R oom/timeout/crash: O/T/X ...".
  last=$(grep -a '^#[0-9]*: cov:' "$logs/fuzz.log" | tail -1)
  execs=$(echo "$last" | sed -n 's/^#\([0-9]*\):.*/\1/p')
  cov=$(echo "$last" | sed -n 's/.* cov: \([0-9]*\).*/\1/p')
  otc=$(echo "$last" | sed -n 's/.*oom\/timeout\/crash: \([0-9/]*\).*/\1/p')
  nfind=$(find "$findings" -type f | wc -l)
  rate=$(( ${execs:-0} / (SECONDS_PER > 0 ? SECONDS_PER : 1) ))
  echo "| $t | $SECONDS_PER | $JOBS | ${execs:-0} | $rate | ${cov:-?} | ${otc:-?} | $nfind |" >> "$SUMMARY"
  if [ "$nfind" -gt 0 ]; then
    status=1
    echo "fuzz: $t: $nfind finding(s) in $findings (replay: $bin FILE)" >&2
  fi
done
cat "$SUMMARY"
exit $status
