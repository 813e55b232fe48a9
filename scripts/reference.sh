#!/usr/bin/env bash
# Installs dependencies, builds Talus, and runs the built-in reference scenario (SPEC §6,
# the bench slope): writes its outputs to out/reference/ and prints their summaries.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
jobs=$(nproc)

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release > /dev/null
cmake --build build -j "$jobs" --target terrain-gen

out=out/reference
mkdir -p "$out"
bin=build/bin

# Terrain: the bench slope at the three roughness levels S1, S2, S3 (R = 1/8, 1/4, 1/2).
for level in S1:0.125 S2:0.25 S3:0.5; do
  name=${level%%:*}
  index=${level##*:}
  "$bin/terrain-gen" -c samples/bench-slope/terrain.yaml --set roughness.roughness_index="$index" \
    -o "$out/terrain-$name.h5" --summary
done
echo "reference: outputs in $out/"
