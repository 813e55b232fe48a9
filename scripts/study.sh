#!/usr/bin/env bash
# The SPEC §6 reference study with tools already built: the bench slope at roughness
# levels S1–S3, blocks R1–R4 (1 m³ each), 250 realizations per block and level, then the
# statistics (tables, CDF plots, hazard maps, convergence). scripts/reference.sh installs,
# builds and runs this; run it alone to time or repeat the study.
#   scripts/study.sh [BIN] [OUT]      (defaults: build/bin, out/reference)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bin=$(realpath -m "${1:-$root/build/bin}")
out=$(realpath -m "${2:-$root/out/reference}")
cd "$root"
mkdir -p "$out"

# Terrain: the bench slope at R = 1/8, 1/4, 1/2 (σ = 0.1, 0.2, 0.4 m); blocks R1–R4:
# tetrahedron, cube, octahedron, dodecahedron, 1 m³ each, in one library. The four are
# independent and small: they run at once (each stops the script if it fails).
pids=()
for level in S1:0.125 S2:0.25 S3:0.5; do
  name=${level%%:*}
  "$bin/terrain-gen" -c samples/bench-slope/terrain.yaml \
    --set roughness.roughness_index="${level##*:}" -o "$out/terrain-$name.h5" &
  pids+=($!)
done
"$bin/block-gen" -c samples/blocks/platonic.yaml -o "$out/platonic.h5" &
pids+=($!)
for pid in "${pids[@]}"; do wait "$pid"; done
"$bin/terrain-gen" "$out/terrain-S2.h5" --summary
"$bin/block-gen" info "$out/platonic.h5"

# 1000 realizations per roughness level (block i mod 4: 250 per block), one thread per core.
for name in S1 S2 S3; do
  "$bin/dda-run" -c samples/bench-slope/scene.yaml --set terrain="$out/terrain-$name.h5" \
    --set block_file="$out/platonic.h5" -o "$out/run-$name.h5"
done

# Statistics: tables (CSV, HDF5), CDF plots with DKW bands, hazard maps, convergence.
"$bin/stats" "$out/run-S1.h5" "$out/run-S2.h5" "$out/run-S3.h5" \
  --set 'names=[S1,S2,S3]' --set 'reach_distances=[36]' -o "$out/stats" --print-table
