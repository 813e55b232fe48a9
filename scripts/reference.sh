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
./scripts/study.sh build/bin "$out"
echo "reference: outputs in $out/ (plots and tables in $out/stats/)"
