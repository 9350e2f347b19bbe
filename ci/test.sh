#!/usr/bin/env bash
# Installs whatever is missing, builds, and runs the whole test suite through
# ctest (GPU tests run on Mesa lavapipe when no GPU is present); then, in a
# second build directory compiled with clang under AddressSanitizer and
# UndefinedBehaviorSanitizer, the CPU unit tests and a bounded run of the
# scene-loader fuzzer (docs/reliability.md).
set -euo pipefail
cd "$(dirname "$0")/.."
bash ci/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j"$(nproc)"
cd build
ctest --output-on-failure --timeout 1500
cd ..
cmake -S . -B build-san -DCMAKE_BUILD_TYPE=Release -DVKMECH_SANITIZE=ON -DCMAKE_CXX_COMPILER=clang++
cmake --build build-san -j"$(nproc)"
ctest --test-dir build-san --output-on-failure --timeout 1500
