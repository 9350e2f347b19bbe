#!/usr/bin/env bash
# vkmech's software-BVH closest-hit throughput beside Intel Embree 3's on the
# same rays and triangles (docs/performance.md "Traversal versus Embree"). A
# benchmark, not a test: run it on a quiet machine.
#
#   bash ci/bench-embree.sh [DUMP_DIR] [-- BENCH_EMBREE_ARGS...]
#
# DUMP_DIR (default out/bench-embree) holds `vkmech bench traversal --dump`
# output; when it has no <scene>.json this script makes it first with
# "${VKMECH:-build/vkmech} bench traversal --dump DUMP_DIR $VKMECH_BENCH_ARGS"
# (all scenes in scenes/, 262144 rays each, seed 1). Then it compiles
# ci/bench_embree.cpp (g++ -O3 -march=native, dlopen of Debian's
# libembree3-3 runtime; no Embree headers needed) and prints, per scene,
# vkmech's rays/s, Embree's on 1 and all threads, their ratio and how many
# closest hits agree. Exit status 3: some scene's hits disagree on > 0.1%.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
DUMP="out/bench-embree"
if [[ $# -gt 0 && "$1" != "--" ]]; then DUMP="$1"; shift; fi
[[ $# -gt 0 && "$1" == "--" ]] && shift
LIB="${EMBREE_LIB:-/usr/lib/x86_64-linux-gnu/libembree3.so.3}"
if [[ ! -e "$LIB" ]]; then
    echo "bench-embree: the Embree 3 library $LIB is missing." >&2
    echo "bench-embree: install it (Debian: apt-get install libembree3-3) or point EMBREE_LIB at libembree3.so.3." >&2
    exit 2
fi
CXX="${CXX:-g++}"
command -v "$CXX" > /dev/null || { echo "bench-embree: no C++ compiler ($CXX)" >&2; exit 2; }

if ! compgen -G "$DUMP/*.json" > /dev/null; then
    VK="${VKMECH:-$ROOT/build/vkmech}"
    [[ -x "$VK" ]] || { echo "bench-embree: $VK not built (cmake --build build) and no dump in $DUMP" >&2; exit 2; }
    echo "== $VK bench traversal --dump $DUMP ${VKMECH_BENCH_ARGS:-}"
    # shellcheck disable=SC2086
    "$VK" bench traversal --dump "$DUMP" ${VKMECH_BENCH_ARGS:-}
fi

BIN="$(mktemp -d)"
trap 'rm -rf "$BIN"' EXIT
"$CXX" -std=c++20 -O3 -march=native -Wall -o "$BIN/bench_embree" "$ROOT/ci/bench_embree.cpp" -ldl
echo "== bench_embree --lib $LIB $DUMP $*"
"$BIN/bench_embree" --lib "$LIB" "$DUMP" "$@"
