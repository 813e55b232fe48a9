#!/usr/bin/env bash
# Sensitivity of the reference study (SPEC §6, bench slope S1-S3, R1-R4) to each purely
# numerical threshold of the engine: the toe fraction (share of blocks whose final
# centroid is past the toe, x >= 36 m, including those that left the terrain there) with the setting
# at its default, halved and doubled, 1000 realizations per run (250 per block), the same
# seed for all runs (common random numbers). Prints a Markdown table.
#
#   bench/dda/threshold_sensitivity.sh [--bin DIR] [--out DIR] [--realizations N] [SETTING ...]
#
# SETTING: engine keys to vary (default: impact_min_normal_speed rest_kinetic_energy
# rest_dwell max_displacement_ratio penalty_omega max_open_close_iterations
# max_step_energy_gain).
# Needs TALUS_PYTHON (default /usr/bin/python3) with h5py and numpy.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/../.." && pwd)
bin="$repo/build/bin"
out="$repo/out/threshold-sensitivity"
n=1000
python=${TALUS_PYTHON:-/usr/bin/python3}
keys=()
while [ $# -gt 0 ]; do
  case $1 in
    --bin) bin=$2; shift ;;
    --out) out=$2; shift ;;
    --realizations) n=$2; shift ;;
    -h|--help) sed -n '2,14p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "threshold_sensitivity.sh: unknown option '$1'" >&2; exit 2 ;;
    *) keys+=("$1") ;;
  esac
  shift
done
[ ${#keys[@]} -gt 0 ] || keys=(impact_min_normal_speed rest_kinetic_energy rest_dwell max_displacement_ratio
                                penalty_omega max_open_close_iterations max_step_energy_gain)
mkdir -p "$out"
levels=(S1:0.125 S2:0.25 S3:0.5)
for level in "${levels[@]}"; do
  [ -f "$out/terrain-${level%%:*}.h5" ] ||
    "$bin/terrain-gen" -q -c "$repo/samples/bench-slope/terrain.yaml" \
      --set roughness.roughness_index="${level##*:}" -o "$out/terrain-${level%%:*}.h5"
done
[ -f "$out/platonic.h5" ] || "$bin/block-gen" -q -c "$repo/samples/blocks/platonic.yaml" -o "$out/platonic.h5"
default_of() { "$bin/dda-run" --print-config | awk -v k="$1:" '$1 == k && !found { print $2; found = 1 }'; }  # reads all: an early exit would SIGPIPE dda-run
toe() {
  "$python" - "$1" <<'PY'
import sys, h5py, numpy as np
with h5py.File(sys.argv[1], "r") as f:
    r = f["records"]
    x = r["final_position"][:, 0]
    print("%.1f" % (100.0 * np.mean(x >= 36.0)))
PY
}
run() {  # name level key value
  local file="$out/$1.h5"
  [ -f "$file" ] || "$bin/dda-run" -q -c "$repo/samples/bench-slope/scene.yaml" \
    --set terrain="$out/terrain-$2.h5" --set block_file="$out/platonic.h5" --set realizations="$n" \
    ${3:+--set "engine.$3=$4"} -o "$file"
  toe "$file"
}
echo "| setting | value | toe S1 (%) | toe S2 (%) | toe S3 (%) | largest change (pp) |"
echo "|---|---|---|---|---|---|"
base=()
for level in "${levels[@]}"; do base+=("$(run "default-${level%%:*}" "${level%%:*}")"); done
echo "| (defaults) | | ${base[0]} | ${base[1]} | ${base[2]} | |"
for key in "${keys[@]}"; do
  d=$(default_of "$key")
  [ -n "$d" ] || { echo "threshold_sensitivity.sh: no engine setting '$key'" >&2; exit 2; }
  for f in 0.5 2; do
    v=$(awk -v d="$d" -v f="$f" -v k="$key" 'BEGIN { x = d * f; if (k ~ /iterations/) x = int(x + 0.5); printf "%.6g", x }')
    row=(); worst=0
    for i in 0 1 2; do
      level=${levels[$i]%%:*}
      t=$(run "$key-$v-$level" "$level" "$key" "$v")
      row+=("$t")
      worst=$(awk -v a="$t" -v b="${base[$i]}" -v w="$worst" 'BEGIN { d = a - b; if (d < 0) d = -d; print (d > w ? d : w) }')
    done
    echo "| \`$key\` | $v ($f × $d) | ${row[0]} | ${row[1]} | ${row[2]} | $worst |"
  done
done
