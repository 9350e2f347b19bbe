#!/usr/bin/env bash
# Self-test of `cmake --install`: installs the build into a temporary prefix,
# then runs the installed binary from an empty directory with no VKMECH_*
# variables set. It must find the scenes, the figure script and the predictor
# curve under <prefix>/share/vkmech (not in the source tree it was built from),
# load every installed scene (their includes too) and render ring_caustic.
# Then the installed data root is renamed: `vkmech paths` must stop reporting
# it (so the checks above can fail), and VKMECH_DATA_DIR must bring it back.
#
# Usage: bash tests/install_selftest.sh CMAKE BUILD_DIR [BINDIR DATADIR]
#   (BINDIR and DATADIR relative to the prefix; default bin and share)
# Exit: 0 all passed; 1 a check failed.
set -uo pipefail

CMAKE="$1"
BUILD="$2"
BINDIR="${3:-bin}"
DATADIR="${4:-share}"
ROOT="$(cd "$(dirname "$0")/.." && pwd)"

TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT
PREFIX="$TMP/prefix"
VK="$PREFIX/$BINDIR/vkmech"
DATA="$PREFIX/$DATADIR/vkmech"
WORK="$TMP/work"  # the working directory: empty, outside the source tree
mkdir -p "$WORK"
unset VKMECH_SCENE_DIR VKMECH_PLOT_SCRIPT VKMECH_DATA_DIR

passed=0
failed=0
ok() { passed=$((passed + 1)); echo "ok   $*"; }
bad() { failed=$((failed + 1)); echo "FAIL $*"; }

# 1. The install itself.
if "$CMAKE" --install "$BUILD" --prefix "$PREFIX" > "$TMP/install.log" 2>&1; then
  ok "cmake --install $BUILD --prefix $PREFIX"
else
  bad "cmake --install failed:"; cat "$TMP/install.log"
  echo "install_selftest: $passed passed, $failed failed"; exit 1
fi
for f in "$VK" "$DATA/plot_figures.py" "$DATA/predictor_curve.json" "$DATA/scenes/ring_caustic.xml"; do
  if [ -f "$f" ]; then ok "installed ${f#"$PREFIX"/}"; else bad "not installed: $f"; fi
done
# Every scene file of the source tree (includes and light sets too) is installed.
src_list="$(cd "$ROOT/scenes" && find . -name '*.xml' | sort)"
inst_list="$(cd "$DATA/scenes" 2>/dev/null && find . -name '*.xml' | sort)"
if [ -n "$src_list" ] && [ "$src_list" = "$inst_list" ]; then ok "all $(echo "$src_list" | wc -l) scene files installed"
else bad "installed scene files differ from scenes/: $(diff <(echo "$src_list") <(echo "$inst_list") | tr '\n' ' ')"; fi

# `vkmech paths` from WORK: each resource found under $1 (with origin $2).
paths_under() {
  local root="$1" origin="$2" out rc what line
  out="$(cd "$WORK" && "$VK" paths 2>&1)"; rc=$?
  local all=0
  for what in "scene directory" "plot script" "predictor curve"; do
    line="$(echo "$out" | grep "^$what: ")"
    case "$line" in
      "$what: $root/"*"($origin)") ;;
      *) all=1; echo "     $what: expected under $root ($origin); vkmech paths said: ${line:-nothing}" ;;
    esac
  done
  [ "$rc" -eq 0 ] && [ "$all" -eq 0 ]
}

# 2. The installed binary finds its data next to itself.
if paths_under "$DATA" "next to the binary"; then ok "vkmech paths: scenes, plot script and curve under $DATA"
else bad "vkmech paths does not report the installed data root"; fi

# 3. Every installed scene loads by name from WORK, from the installed file.
for s in "$DATA"/scenes/*.xml; do
  name="$(basename "$s" .xml)"
  out="$(cd "$WORK" && "$VK" check --scene "$name" 2>&1)"; rc=$?
  if [ "$rc" -eq 0 ] && echo "$out" | grep -qxF "scene: $s"; then ok "vkmech check --scene $name: $s"
  else bad "vkmech check --scene $name (exit $rc): $(echo "$out" | head -3 | tr '\n' ' ')"; fi
done

# 4. A render from WORK writes its EXR where --out says, and nothing in WORK.
out="$(cd "$WORK" && "$VK" render --scene ring_caustic --spp 4 --res 16 --out "$TMP/out" --pipeline-cache off 2>&1)"; rc=$?
if [ "$rc" -eq 0 ] && [ -s "$TMP/out/ring_caustic.exr" ]; then ok "vkmech render --scene ring_caustic: $TMP/out/ring_caustic.exr"
else bad "vkmech render --scene ring_caustic (exit $rc): $(echo "$out" | tail -3 | tr '\n' ' ')"; fi
if grep -qF "$DATA/scenes/ring_caustic.xml" "$TMP/out/ring_caustic.json" 2>/dev/null; then ok "the render's JSON names the installed scene"
else bad "the render's JSON does not name $DATA/scenes/ring_caustic.xml"; fi
if [ -z "$(ls -A "$WORK")" ]; then ok "nothing written to the working directory"; else bad "files in the working directory: $(ls -A "$WORK")"; fi

# 5. The installed figure script runs (its usage needs no matplotlib).
if python3 "$DATA/plot_figures.py" --help > /dev/null 2>&1; then ok "python3 $DATA/plot_figures.py --help"
else bad "the installed plot script does not run"; fi

# 6. The checks can fail: with the data root renamed, the binary no longer
#    reports it; VKMECH_DATA_DIR pointing at the new name brings it back.
mv "$DATA" "$DATA.moved"
if paths_under "$DATA" "next to the binary" > /dev/null; then bad "vkmech paths still reports $DATA after it was renamed"
else ok "with $DATA renamed, vkmech paths no longer reports it"; fi
export VKMECH_DATA_DIR="$DATA.moved"
if paths_under "$DATA.moved" '$VKMECH_DATA_DIR'; then ok "VKMECH_DATA_DIR=$DATA.moved overrides the lookup"
else bad "VKMECH_DATA_DIR=$DATA.moved is not used"; fi
unset VKMECH_DATA_DIR

echo "install_selftest: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
