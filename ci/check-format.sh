#!/usr/bin/env bash
# Every C++ file of host/, analysis/ and tests/ as .clang-format formats it.
# Usage: bash ci/check-format.sh [--fix]   (run from anywhere inside the checkout)
# Exit 0 when all are formatted; 1 listing the files that are not (apply with
# --fix, or `clang-format -i FILE`); 2 when clang-format or git is missing.
set -u
cd "$(dirname "$0")/.." || exit 2
command -v clang-format >/dev/null || { echo "check-format: clang-format not found: apt install clang-format (ci/install-deps.sh does)"; exit 2; }
mapfile -t files < <(git ls-files 'host/*.cpp' 'host/*.hpp' 'analysis/*.cpp' 'analysis/*.hpp' 'tests/*.cpp' 'tests/*.hpp') \
    || { echo "check-format: git ls-files failed (not a git checkout?)"; exit 2; }
[[ ${#files[@]} -gt 0 ]] || { echo "check-format: no C++ files found: not a git checkout?"; exit 2; }
if [[ ${1:-} == --fix ]]; then
    clang-format -i "${files[@]}"
    exit 0
fi
bad=()
for f in "${files[@]}"; do
    clang-format --dry-run -Werror "$f" >/dev/null 2>&1 || bad+=("$f")
done
if [[ ${#bad[@]} -gt 0 ]]; then
    printf 'check-format: not formatted: %s\n' "${bad[@]}"
    echo "check-format: ${#bad[@]} of ${#files[@]} files differ from .clang-format; run: bash ci/check-format.sh --fix"
    exit 1
fi
echo "check-format: ${#files[@]} files formatted"
