#!/usr/bin/env bash
# A bounded libFuzzer run of the scene loader (tests/fuzz/fuzz_loader.cpp).
#   run.sh FUZZER WORKDIR SECONDS [extra libFuzzer flags...]
# Seeds WORKDIR/corpus from tests/data (seeds.py), first replays every saved
# reproducer in tests/fuzz/regressions, then fuzzes for SECONDS. Any crash,
# sanitizer report, timeout (a hang: > 10 s on one input; FUZZ_TIMEOUT=N seconds
# on a loaded machine, where a niced fuzzer can wait longer than that) or out-of-memory
# (> 2 GiB) fails the run; libFuzzer leaves the input as WORKDIR/crash-*,
# timeout-* or oom-*, which belongs in tests/fuzz/regressions once fixed.
set -euo pipefail
fuzzer=$1 work=$2 seconds=$3
shift 3
here="$(cd "$(dirname "$0")" && pwd)"
py=python3
[ -x /usr/bin/python3 ] && py=/usr/bin/python3
mkdir -p "$work/corpus"
"$py" "$here/seeds.py" "$work/corpus"
export ASAN_OPTIONS="detect_leaks=0:${ASAN_OPTIONS:-}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:${UBSAN_OPTIONS:-}"
flags=(-timeout="${FUZZ_TIMEOUT:-10}" -rss_limit_mb=2048 -max_len=65536 -artifact_prefix="$work/")
regressions=("$here"/regressions/*)
if [ -e "${regressions[0]}" ]; then
  echo "fuzz: replaying ${#regressions[@]} saved reproducers"
  "$fuzzer" "${flags[@]}" "${regressions[@]}"
fi
echo "fuzz: $seconds s on the loader"
"$fuzzer" "${flags[@]}" -max_total_time="$seconds" -print_final_stats=1 "$@" "$work/corpus"
echo "fuzz: no crash, hang, out-of-memory or sanitizer report in $seconds s"
