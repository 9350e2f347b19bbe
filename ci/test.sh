#!/usr/bin/env bash
# Installs whatever is missing, builds, and runs the whole test suite through
# ctest (GPU tests run on Mesa lavapipe when no GPU is present); then, in a
# second build directory compiled with clang under AddressSanitizer and
# UndefinedBehaviorSanitizer, the CPU unit tests and a bounded run of the
# scene-loader fuzzer (docs/reliability.md).
# ctest runs as many tests at once as there are cores: most cases are one
# thread of host work around a short lavapipe render, so two at a time on the
# 2-core CI machine take about 60 % of the serial time (docs/reliability.md).
# Each stage prints its elapsed time, so a slow stage is visible in CI's log.
set -euo pipefail
cd "$(dirname "$0")/.."
start=$SECONDS
stage() { echo "== ci/test.sh: $1 ($((SECONDS - start)) s since the start)"; }
jobs="$(nproc)"
stage "dependencies"
bash ci/install-deps.sh
# Ninja schedules every target's compilations as one graph (a target's objects need not wait for the
# libraries it links), which builds faster than make on two cores (docs/reliability.md). CMake reads
# CMAKE_GENERATOR only when it creates a build directory: one made earlier keeps its generator.
if command -v ninja > /dev/null 2>&1; then export CMAKE_GENERATOR="${CMAKE_GENERATOR:-Ninja}"; fi
stage "build"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j"$jobs"
stage "tests"
(cd build && ctest --output-on-failure --timeout 1500 -j"$jobs")
stage "sanitizer build"
cmake -S . -B build-san -DCMAKE_BUILD_TYPE=Release -DVKMECH_SANITIZE=ON -DCMAKE_CXX_COMPILER=clang++
cmake --build build-san -j"$jobs"
stage "sanitizer tests"
ctest --test-dir build-san --output-on-failure --timeout 1500 -j"$jobs"
stage "done"
