#!/usr/bin/env bash
# Installs dependencies, builds, and runs the whole test suite twice: a Release build,
# then a build under AddressSanitizer + UndefinedBehaviorSanitizer.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
jobs=$(nproc)

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DTALUS_WERROR=ON -DTALUS_WITH_MPI=ON > /dev/null
cmake --build build -j "$jobs"
ctest --test-dir build --output-on-failure -j "$jobs"

# Line tables only (-g1): the sanitizers' reports name file and line, and the build takes
# about a quarter of the disk that full debug information needs (about 1 GB, not 4).
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=Debug -DTALUS_SANITIZE=ON -DTALUS_BUILD_BENCHMARKS=OFF \
      -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g1" > /dev/null
cmake --build build-asan -j "$jobs"
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir build-asan --output-on-failure -j "$jobs"
