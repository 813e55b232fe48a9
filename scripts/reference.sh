#!/usr/bin/env bash
# Installs dependencies, builds Talus, and runs the built-in reference scenario (SPEC §6):
# the bench slope at roughness levels S1–S3, blocks R1–R4 (1 m³ each), 250 realizations per
# block and level, then the statistics: CDF plots, hazard maps and the summary table.
# Outputs go to out/reference/.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
jobs=$(nproc)

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release > /dev/null
cmake --build build -j "$jobs" --target terrain-gen block-gen dda-run stats

out=out/reference
bin=build/bin
mkdir -p "$out"

# Terrain: the bench slope at R = 1/8, 1/4, 1/2 (σ = 0.1, 0.2, 0.4 m).
for level in S1:0.125 S2:0.25 S3:0.5; do
  name=${level%%:*}
  "$bin/terrain-gen" -c samples/bench-slope/terrain.yaml \
    --set roughness.roughness_index="${level##*:}" -o "$out/terrain-$name.h5"
done
"$bin/terrain-gen" "$out/terrain-S2.h5" --summary

# Blocks R1–R4: tetrahedron, cube, octahedron, dodecahedron, 1 m³ each, in one library.
"$bin/block-gen" -c samples/blocks/platonic.yaml -o "$out/platonic.h5"
"$bin/block-gen" info "$out/platonic.h5"

# 1000 realizations per roughness level (block i mod 4: 250 per block).
for name in S1 S2 S3; do
  "$bin/dda-run" -c samples/bench-slope/scene.yaml --set terrain="$out/terrain-$name.h5" \
    --set block_file="$out/platonic.h5" -o "$out/run-$name.h5"
done

# Statistics: tables (CSV, HDF5), CDF plots with DKW bands, hazard maps, convergence.
"$bin/stats" "$out/run-S1.h5" "$out/run-S2.h5" "$out/run-S3.h5" \
  --set 'names=[S1,S2,S3]' --set 'reach_distances=[36]' -o "$out/stats" --print-table
echo "reference: outputs in $out/ (plots and tables in $out/stats/)"
