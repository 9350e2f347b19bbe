#!/usr/bin/env bash
# Self-test for analysis/plot_figures.py: draws the sample specs in
# tests/data/plots/ (in a temporary copy), checks every PNG, checks that
# malformed specs are reported by name with exit status 2 while the good ones
# are still drawn, and that drawing twice gives byte-identical files.
#
# Usage: bash tests/plots_selftest.sh   (PYTHON=... to pick the interpreter)
# Exit: 0 all passed; 1 a check failed; 77 skipped (no python with matplotlib).
set -uo pipefail

HERE="$(cd "$(dirname "$0")" && pwd)"
ROOT="$(dirname "$HERE")"
SCRIPT="$ROOT/analysis/plot_figures.py"
DATA="$HERE/data/plots"

# An interpreter with matplotlib: $PYTHON, else python3, else Debian's.
PY=""
for cand in ${PYTHON:-} python3 /usr/bin/python3; do
  if command -v "$cand" >/dev/null 2>&1 && "$cand" -c 'import matplotlib' >/dev/null 2>&1; then
    PY="$cand"; break
  fi
done
if [ -z "$PY" ]; then
  echo "plots_selftest: SKIP: no python3 with matplotlib (apt-get install python3-matplotlib)"
  exit 77
fi

TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT
passed=0
failed=0
ok() { passed=$((passed + 1)); echo "ok   $*"; }
bad() { failed=$((failed + 1)); echo "FAIL $*"; }

mkdir -p "$TMP/good" "$TMP/bad"
cp "$DATA"/*.json "$TMP/good/"
cp "$DATA"/bad/*.json "$TMP/bad/"
# More malformed specs, each must be reported by name.
printf '{"title": "no panels", "panels": []}\n' > "$TMP/bad/zero_panels.json"
printf '{"panels": [{"kind": "line", "series": [{"x": [1, 2], "y": [1' > "$TMP/bad/truncated.json"
printf '{"panels": [{"kind": "bar", "categories": ["a", "b"], "series": [{"y": [1]}]}]}\n' \
  > "$TMP/bad/bar_length.json"

expected=()
for f in "$TMP"/good/*.json; do expected+=("${f%.json}.png"); done
if [ ${#expected[@]} -lt 3 ]; then bad "fewer than 3 sample specs in $DATA"; fi

# 1. The good specs: exit 0, one line per PNG, every PNG valid and > 5 kB.
"$PY" "$SCRIPT" "$TMP/good" > "$TMP/out1" 2> "$TMP/err1"
rc=$?
if [ $rc -eq 0 ]; then ok "good specs: exit 0"; else bad "good specs: exit $rc: $(cat "$TMP/err1")"; fi
if [ -s "$TMP/err1" ]; then bad "good specs: unexpected stderr: $(cat "$TMP/err1")"; else ok "good specs: no warnings"; fi
lines=$(wc -l < "$TMP/out1")
if [ "$lines" -eq ${#expected[@]} ]; then ok "one output line per PNG ($lines)"; else bad "expected ${#expected[@]} output lines, got $lines"; fi

check_png() {
  local png="$1" magic size
  if [ ! -f "$png" ]; then bad "missing $(basename "$png")"; return; fi
  magic=$(head -c 8 "$png" | od -An -tx1 | tr -d ' \n')
  if [ "$magic" != "89504e470d0a1a0a" ]; then bad "$(basename "$png") is not a PNG (magic $magic)"; return; fi
  size=$(wc -c < "$png")
  if [ "$size" -le 5120 ]; then bad "$(basename "$png") is only $size bytes"; return; fi
  ok "$(basename "$png") is a PNG of $size bytes"
}
for png in "${expected[@]}"; do check_png "$png"; done
leftovers=$(find "$TMP/good" -name '*.tmp' | wc -l)
if [ "$leftovers" -eq 0 ]; then ok "no temporary files left"; else bad "$leftovers temporary files left"; fi

# 2. Deterministic: a second run gives byte-identical PNGs.
mkdir -p "$TMP/first"
cp "${expected[@]}" "$TMP/first/"
"$PY" "$SCRIPT" "$TMP/good" > /dev/null 2>&1 || bad "second run failed"
for png in "${expected[@]}"; do
  if cmp -s "$png" "$TMP/first/$(basename "$png")"; then ok "$(basename "$png") identical on rerun"
  else bad "$(basename "$png") differs between two runs"; fi
done

# 3. Malformed specs (mixed with a good one given by file): exit 2, each bad
#    file named on stderr in the 'plot_figures: FILE: ...' form, the good one
#    still drawn, no PNG for the bad ones.
rm -f "${expected[0]}"
"$PY" "$SCRIPT" "$TMP/bad" "${expected[0]%.png}.json" > "$TMP/out3" 2> "$TMP/err3"
rc=$?
if [ $rc -eq 2 ]; then ok "malformed specs: exit 2"; else bad "malformed specs: exit $rc, expected 2"; fi
for f in "$TMP"/bad/*.json; do
  if grep -qF "plot_figures: $f: " "$TMP/err3"; then ok "error names $(basename "$f"): $(grep -F "$f" "$TMP/err3" | head -1 | sed "s|^plot_figures: $f: ||")"
  else bad "no 'plot_figures: $f: ...' message; stderr was: $(cat "$TMP/err3")"; fi
  if [ -e "${f%.json}.png" ]; then bad "a PNG was written for malformed $(basename "$f")"; fi
done
if [ -f "${expected[0]}" ] && grep -qxF "${expected[0]}" "$TMP/out3"; then ok "good spec still drawn alongside malformed ones"
else bad "good spec not drawn when run with malformed ones"; fi

# 4. A missing argument is an error too.
"$PY" "$SCRIPT" "$TMP/does_not_exist.json" > /dev/null 2> "$TMP/err4"
rc=$?
if [ $rc -eq 2 ] && grep -qF "does_not_exist.json" "$TMP/err4"; then ok "missing file: exit 2 and named"
else bad "missing file: exit $rc, stderr: $(cat "$TMP/err4")"; fi

echo "plots_selftest: $passed passed, $failed failed"
[ $failed -eq 0 ]
