#!/usr/bin/env bash
# Scale-out self-test (README "Studies on many machines"): two workers sharing
# one render cache produce tables byte-identical to a single-process study.
#   1. `study all --preset quick` on two scenes in one process (reference tables);
#   2. --analyse-only on an empty cache refuses (exit 1) and names what is missing;
#   3. two concurrent workers under GNU parallel (ci/install-deps.sh installs
#      it; without it, xargs -P 2 runs them the same way) render
#      --shard 0/2 and --shard 1/2 into one cache, then --analyse-only builds
#      the tables: ci/compare-outputs.py must find no difference (timing tables
#      and the report header are measurements and are skipped);
#   4. the same for `study stability` through the commands of --jobs FILE, one
#      per missing work unit, run by two concurrent workers.
# Usage: bash tests/scaleout_selftest.sh VKMECH PYTHON
# Exit: 0 all passed; 1 a check failed.
set -uo pipefail
VK="$1"
PY="$2"
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
# Two scenes (the sweeps keep their own): the sharding is what is tested, and the whole quick
# study twice took 3.5 of CI's 30 minutes.
SCENES="--scenes cubes_dof,glass_caustic"
TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT
fail=0
if command -v parallel > /dev/null 2>&1; then
    echo "workers: GNU parallel ($(parallel --will-cite --version | head -1))"
    shard_workers() { parallel --will-cite -j 2 "$VK" study all --preset quick $SCENES --no-plots --out "$TMP/shared" --shard {} ::: 0/2 1/2; }
    job_workers() { parallel --will-cite -j 2 < "$1"; }
else
    echo "workers: xargs -P 2 (GNU parallel is not installed)"
    shard_workers() {
        printf '0/2\n1/2\n' | xargs -P 2 -I{} "$VK" study all --preset quick $SCENES --no-plots --out "$TMP/shared" --shard {}
    }
    job_workers() { xargs -P 2 -I{} bash -c '{}' < "$1"; }
fi
check() {  # check "what" command...
    local what="$1"
    shift
    if "$@"; then echo "PASS: $what"; else echo "FAIL: $what"; fail=1; fi
}

"$VK" study all --preset quick $SCENES --no-plots --out "$TMP/single" > "$TMP/single.log" 2>&1 ||
    { echo "FAIL: the single-process study"; tail -20 "$TMP/single.log"; exit 1; }

"$VK" study all --preset quick $SCENES --no-plots --out "$TMP/shared" --analyse-only > "$TMP/empty.log" 2>&1
rc=$?
check "--analyse-only on an empty cache exits 1" test "$rc" -eq 1
check "--analyse-only names what is missing" grep -q "lacks" "$TMP/empty.log"
check "--analyse-only rendered nothing" test -z "$(ls -A "$TMP/shared/cache" 2>/dev/null | grep -v '^\.' || true)"

shard_workers > "$TMP/shards.log" 2>&1
check "two concurrent shard workers succeed" test $? -eq 0
check "each shard wrote no table" test ! -e "$TMP/shared/tables"
"$VK" study all --preset quick $SCENES --no-plots --out "$TMP/shared" --analyse-only > "$TMP/analyse.log" 2>&1
check "--analyse-only on the complete cache succeeds" test $? -eq 0
check "shards + --analyse-only tables are byte-identical to the single process" \
    "$PY" "$ROOT/ci/compare-outputs.py" "$TMP/single" "$TMP/shared"
check "no temporary left in the shared cache" test -z "$(ls "$TMP/shared/cache" | grep 'tmp-' || true)"

"$VK" study stability --preset quick $SCENES --no-plots --out "$TMP/stab1" > /dev/null 2>&1
"$VK" study stability --preset quick $SCENES --no-plots --out "$TMP/stab2" --jobs "$TMP/jobs.txt" > "$TMP/jobs.log" 2>&1
check "--jobs writes one command per missing work unit" test "$(wc -l < "$TMP/jobs.txt")" -gt 1
check "--jobs rendered nothing" test -z "$(ls -A "$TMP/stab2/cache" 2>/dev/null | grep -v '^\.' || true)"
job_workers "$TMP/jobs.txt" > "$TMP/jobworkers.log" 2>&1
check "two workers ran every job" test $? -eq 0
"$VK" study stability --preset quick $SCENES --no-plots --out "$TMP/stab2" --jobs "$TMP/jobs2.txt" > /dev/null 2>&1
check "after the jobs, --jobs lists nothing" test ! -s "$TMP/jobs2.txt"
"$VK" study stability --preset quick $SCENES --no-plots --out "$TMP/stab2" --analyse-only > /dev/null 2>&1
check "--jobs + --analyse-only tables are byte-identical to the single process" \
    "$PY" "$ROOT/ci/compare-outputs.py" "$TMP/stab1" "$TMP/stab2"
exit $fail
