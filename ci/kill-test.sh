#!/usr/bin/env bash
# Kill test (docs/reliability.md, "Killing renders and studies"): SIGKILL a render and a study at random moments and
# check that nothing they leave is ever a mixed or partial result.
#
# Renders: a complete output set is written first; then RENDER_KILLS times a
# render (random --spp 1..16, --res 32..64) into the same --out is killed
# with SIGKILL after a random delay in [0, T] (T: the time of one whole
# render). After every kill `vkmech verify outputs` must find no bad set and
# either a complete set (the old one, or the new one when the kill came after
# the commit) or a pending commit (the new set, finished by the next run).
# Every fifth kill is a SIGKILL raised inside the commit (VKMECH_FAULT), the
# short window a random moment rarely hits. After every other kill a whole render runs: it must leave one complete set
# and no temporaries (`.vkmech-tmp-*`, `.vkmech-commit-*`, `*.tmp-<pid>`).
#
# Studies: a small quick study writing a render cache is killed STUDY_KILLS
# times at random moments; after each kill `vkmech verify cache` must report
# no bad file; at the end a rerun completes and the cache verifies clean.
#
# Usage: ci/kill-test.sh [path/to/vkmech]   (env: RENDER_KILLS=50 STUDY_KILLS=20 SCENE=cubes_dof SEED=<n>)
# Prints a summary; exits 1 on any violation.
set -u
cd "$(dirname "$0")/.."
VKMECH=${1:-build/vkmech}
RENDER_KILLS=${RENDER_KILLS:-50}
STUDY_KILLS=${STUDY_KILLS:-20}
SCENE=${SCENE:-cubes_dof}
RANDOM=${SEED:-$$}
WORK=$(mktemp -d "${TMPDIR:-/tmp}/vkmech-kill.XXXXXX")
trap 'rm -rf "$WORK"' EXIT
[ -x "$VKMECH" ] || { echo "kill-test: no vkmech binary at $VKMECH (build first)"; exit 2; }

violations=0
violation() { echo "VIOLATION: $*"; violations=$((violations + 1)); }
now_ms() { date +%s%3N; }
# Sleeps a random number of milliseconds in [0, $1].
random_sleep() { local ms=$(( (RANDOM * 32768 + RANDOM) % ($1 + 1) )); sleep "$(printf '%d.%03d' $((ms / 1000)) $((ms % 1000)))"; }
temporaries() { find "$1" -maxdepth 1 \( -name '.vkmech-tmp-*' -o -name '.vkmech-commit-*' -o -name '*.tmp-[0-9]*' \) | wc -l; }
run_id() { sed -n 's/.*"run_id": "\([0-9a-f]*\)".*/\1/p' "$1/$SCENE.manifest.json" 2>/dev/null; }

# ---- renders ----
OUT=$WORK/render
"$VKMECH" render --scene "$SCENE" --spp 16 --res 64 --out "$OUT" > "$WORK/first.log" 2>&1 \
    || { cat "$WORK/first.log"; echo "kill-test: the first render failed"; exit 2; }
t0=$(now_ms)
"$VKMECH" render --scene "$SCENE" --spp 16 --res 64 --out "$OUT" > /dev/null 2>&1 || violation "a whole render failed"
T=$(( $(now_ms) - t0 + 50 ))
echo "kill-test: render of $SCENE takes ~${T} ms; $RENDER_KILLS kills at random moments in [0, $T] ms"
old_kept=0 new_committed=0 pending_seen=0 finished_before_kill=0
for i in $(seq 1 "$RENDER_KILLS"); do
    old=$(run_id "$OUT")
    spp=$((1 + RANDOM % 16)) res=$((32 + RANDOM % 33))
    # Every fifth kill lands inside the commit itself (fault injection: SIGKILL raised at that exact step),
    # since a random moment rarely falls in that short window.
    fault=""
    if [ $((i % 5)) -eq 0 ]; then
        points=(commit-staged commit-moving commit-moved-one staged-.png staged-.json)
        fault="${points[$(( (i / 5) % ${#points[@]} ))]}:KILL"
    fi
    VKMECH_FAULT=$fault "$VKMECH" render --scene "$SCENE" --spp "$spp" --res "$res" --out "$OUT" > /dev/null 2>&1 &
    pid=$!
    [ -z "$fault" ] && random_sleep "$T"
    [ -z "$fault" ] && kill -9 "$pid" 2> /dev/null
    wait "$pid" 2> /dev/null
    rc=$?
    [ "$rc" -eq 0 ] && finished_before_kill=$((finished_before_kill + 1))
    if ! "$VKMECH" verify outputs "$OUT" > "$WORK/verify.txt" 2>&1; then
        violation "kill $i (--spp $spp --res $res): a bad output set"; cat "$WORK/verify.txt"
    fi
    complete=$(grep -c '^complete' "$WORK/verify.txt") pending=$(grep -c '^pending' "$WORK/verify.txt")
    if [ "$complete" -eq 0 ] && [ "$pending" -eq 0 ]; then
        violation "kill $i: neither a complete set nor a pending commit"; cat "$WORK/verify.txt"
    fi
    if [ "$pending" -gt 0 ]; then pending_seen=$((pending_seen + 1))
    elif [ "$(run_id "$OUT")" = "$old" ]; then old_kept=$((old_kept + 1))
    else new_committed=$((new_committed + 1)); fi
    if [ $((i % 2)) -eq 0 ] || [ "$i" -eq "$RENDER_KILLS" ]; then
        "$VKMECH" render --scene "$SCENE" --spp 2 --res 32 --out "$OUT" > "$WORK/next.log" 2>&1 \
            || { violation "kill $i: the next render failed"; cat "$WORK/next.log"; }
        [ "$(temporaries "$OUT")" -eq 0 ] || { violation "kill $i: temporaries remain after the next run"; ls -A "$OUT"; }
        "$VKMECH" verify outputs "$OUT" > "$WORK/verify.txt" 2>&1 && grep -q '^complete' "$WORK/verify.txt" \
            || { violation "kill $i: the next run left no complete set"; cat "$WORK/verify.txt"; }
    fi
done
echo "kill-test: renders: $RENDER_KILLS kills: old set kept $old_kept, new set committed $new_committed, commit pending" \
     "(finished by the next run) $pending_seen, finished before the kill $finished_before_kill"

# ---- studies ----
SOUT=$WORK/study
# Large enough that rendering, not start-up, fills most of the run (~3 s on 2 cores).
STUDY=(study stability --preset quick --scenes "$SCENE" --res 48 --spp-levels 4,16,64,512 --no-plots)
study() { "$VKMECH" "${STUDY[@]}" --out "$1"; }
t0=$(now_ms)
study "$WORK/study-timing" > "$WORK/study.log" 2>&1 || { cat "$WORK/study.log"; echo "kill-test: the study failed"; exit 2; }
TS=$(( $(now_ms) - t0 ))
echo "kill-test: study takes ~${TS} ms; $STUDY_KILLS kills at random moments in [0, $TS] ms"
frames_max=0
for i in $(seq 1 "$STUDY_KILLS"); do
    "$VKMECH" "${STUDY[@]}" --out "$SOUT" > /dev/null 2>&1 &  # $! must be vkmech itself, not a subshell
    pid=$!
    random_sleep "$TS"
    kill -9 "$pid" 2> /dev/null
    wait "$pid" 2> /dev/null
    if [ -d "$SOUT/cache" ]; then
        "$VKMECH" verify cache "$SOUT/cache" > "$WORK/cverify.txt" 2>&1 \
            || { violation "study kill $i: bad cache files"; cat "$WORK/cverify.txt"; }
        n=$(find "$SOUT/cache" -name '*.frame' | wc -l)
        [ "$n" -gt "$frames_max" ] && frames_max=$n
    fi
    # Every third kill starts the next from an empty cache, so kills keep landing all over the plan.
    [ $((i % 3)) -eq 0 ] && rm -rf "$SOUT"
done
study "$SOUT" > "$WORK/study.log" 2>&1 || { violation "the study rerun failed"; tail -5 "$WORK/study.log"; }
[ -f "$SOUT/report.md" ] || violation "the study rerun wrote no report"
"$VKMECH" verify cache "$SOUT/cache" > "$WORK/cverify.txt" 2>&1 || { violation "the cache is not clean after the rerun"; cat "$WORK/cverify.txt"; }
grep -q ' 0 bad, 0 stale' "$WORK/cverify.txt" || { violation "bad or stale cache files after the rerun"; cat "$WORK/cverify.txt"; }
diff -r "$SOUT/tables" "$WORK/study-timing/tables" > /dev/null || violation "the rerun's tables differ from an uninterrupted study's"
echo "kill-test: studies: $STUDY_KILLS kills (up to $frames_max frames cached at a kill); $(tail -1 "$WORK/cverify.txt")"

if [ "$violations" -eq 0 ]; then
    echo "kill-test: PASS ($RENDER_KILLS render kills, $STUDY_KILLS study kills, no violation)"
    exit 0
fi
echo "kill-test: FAIL: $violations violations"
exit 1
