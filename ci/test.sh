#!/usr/bin/env bash
# Installs whatever is missing, builds, and runs the whole test suite through
# ctest (GPU tests run on Mesa lavapipe when no GPU is present).
set -euo pipefail
cd "$(dirname "$0")/.."
bash ci/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j"$(nproc)"
cd build
ctest --output-on-failure --timeout 1500
