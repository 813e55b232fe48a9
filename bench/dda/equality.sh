#!/usr/bin/env bash
# Record equality of two builds of the engine: runs a fixed set of scenes through the
# public tools with one build, then compares the run files of two such sets with h5diff
# (/records, /crossings, /trajectories, bit for bit: same_records.py). A change of form only (a restructuring, a speed-up
# that claims the same bits) must leave every one of them identical.
#
#   bench/dda/equality.sh run [--bin DIR] [--out DIR] [--quick]
#   bench/dda/equality.sh compare DIR_A DIR_B
#
# The set (docs/benchmarks.md, "Record equality"): the reference study (S1, S2, S3, 1 000
# platonic realizations each), 60 of them with trajectories, the convex detail law E20 …
# E20480 and the concave C20480 on S2, two hull rocks, E1280 and E5120 at three release
# points of the surveyed quarry TIN, the 12-DOF path (platonic and E1280) and the quick
# numerical stress suite. --quick runs a tenth of the realizations and no stress suite.
set -euo pipefail
{
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/../.." && pwd)

usage() { awk 'NR > 1 && !/^#/ { exit } NR > 1 { sub(/^# ?/, ""); print }' "${BASH_SOURCE[0]}"; }

[ $# -ge 1 ] || { usage >&2; exit 2; }
mode=$1; shift
case $mode in
  -h|--help) usage; exit 0 ;;
  compare)
    [ $# -eq 2 ] || { echo "equality.sh: compare needs two directories" >&2; exit 2; }
    a=$1 b=$2 failed=0 compared=0
    while IFS= read -r fa; do
      rel=${fa#"$a"/}
      fb="$b/$rel"
      if [ ! -e "$fb" ]; then echo "missing  $rel (in $b)"; failed=1; continue; fi
      compared=$((compared + 1))
      "$here/same_records.py" "$fa" "$fb" || failed=1
    done < <(find "$a/runs" "$a/stress/runs" -name '*.h5' 2>/dev/null | sort)
    echo "equality.sh: $compared run files compared, $([ $failed = 0 ] && echo 'all identical' || echo 'some differ')"
    exit $failed ;;
  run) ;;
  *) echo "equality.sh: unknown mode '$mode' (run or compare)" >&2; exit 2 ;;
esac

bin="$repo/build/bin"
out="$repo/out/equality"
quick=0
while [ $# -gt 0 ]; do
  case $1 in
    --bin) bin=$(realpath "$2"); shift ;;
    --out) out=$(realpath -m "$2"); shift ;;
    --quick) quick=1 ;;
    *) echo "equality.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
  shift
done
n() { if [ $quick = 1 ]; then echo $(( ($1 + 9) / 10 )); else echo "$1"; fi; }

mkdir -p "$out/inputs" "$out/runs"
in=$out/inputs
cd "$repo"
for level in S1:0.125 S2:0.25 S3:0.5; do
  "$bin/terrain-gen" -c samples/bench-slope/terrain.yaml --set "roughness.roughness_index=${level#*:}" \
    -o "$in/terrain-${level%%:*}.h5" -q
done
"$bin/terrain-gen" -c configs/terrain/surveyed-tin.yaml samples/terrain/bench-floor.obj samples/terrain/face.obj \
  samples/terrain/scree.stl -o "$in/tin.h5" -q
"$bin/block-gen" -c samples/blocks/platonic.yaml -o "$in/platonic.h5" -q
"$bin/block-gen" -c bench/dda/detail-law.yaml -o "$in/detail-law.h5" -q
"$bin/block-gen" -c bench/dda/concave-law.yaml -o "$in/concave-law.h5" -q
"$bin/block-gen" -c bench/dda/hull-rocks.yaml -o "$in/hull-rocks.h5" -q

scene=samples/bench-slope/scene.yaml
run() {  # NAME TERRAIN BLOCKFILE REALIZATIONS [--set ...]
  local name=$1 terrain=$2 blocks=$3 count=$4; shift 4
  "$bin/dda-run" -c "$scene" --set "terrain=$in/$terrain" --set "block_file=$in/$blocks" \
    --set "realizations=$(n "$count")" --threads 2 -q "$@" -o "$out/runs/$name.h5"
  echo "equality.sh: $name"
}
for level in S1 S2 S3; do run "reference-$level" "terrain-$level.h5" platonic.h5 1000; done
run trajectories-S2 terrain-S2.h5 platonic.h5 60 --set engine.trajectory_interval=0.02
for block in E20 E500 E1280 E5120 E20480; do
  run "detail-$block" terrain-S2.h5 detail-law.h5 40 --set "blocks=[$block]"
done
run detail-C20480 terrain-S2.h5 concave-law.h5 20 --set "blocks=[C20480]"
for block in H400 H4000; do run "hull-$block" terrain-S2.h5 hull-rocks.h5 40 --set "blocks=[$block]"; done
i=0
for point in 2601525,1180650 2601530,1180662 2601535,1180645; do
  i=$((i + 1))
  for block in E1280 E5120; do
    run "quarry-$block-$i" tin.h5 detail-law.h5 30 --set "blocks=[$block]" --set "release.points=[[$point]]" \
      --set 'stop_zones=[]' --set 'outputs.barriers=[]'
  done
done
run full12-platonic terrain-S2.h5 platonic.h5 200 --set engine.dof=full12
run full12-E1280 terrain-S2.h5 detail-law.h5 8 --set engine.dof=full12 --set "blocks=[E1280]"
if [ $quick = 0 ]; then
  bench/stress/stress.sh --quick --bin "$bin" --out "$out/stress" > "$out/stress.log"
  echo "equality.sh: stress suite (quick)"
fi
}
