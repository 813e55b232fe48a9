#!/usr/bin/env bash
# Numerical stress suite of the DDA engine, driven only through the public tools
# (terrain-gen -> block-gen -> dda-run), so it measures what a user sees. It writes every
# input itself (synthetic slopes, ESRI ASCII DEMs, OBJ meshes, block libraries), runs
# dda-run on each case with a fixed seed and prints, per case, the realizations by end
# reason. Numerical failures (end reasons non_finite, no_convergence, penetration, and
# realizations with invariant_violations > 0 when the run file has that column), cases
# that leave no complete run file and analytic cases off their target all make the exit
# status 1. Nothing is hidden: step_limit ends are shown but are not failures.
#
#   bench/stress/stress.sh [--ci|--quick|--full] [--bin DIR] [--out DIR] [--jobs N]
#                          [--groups g1,g2] [--markdown]
#
# Modes: --ci (a subset for CTest, under a minute in Release), --quick (default, 2-3 min
# on one core), --full (many realizations per case, tens of minutes). docs/benchmarks.md
# ("Numerical stress suite") lists the cases.
set -euo pipefail
# The whole script is one compound command, read before any of it runs: editing this file
# while a long run is going cannot change what that run does.
{

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/../.." && pwd)
tool="$here/stress_tool.py"
python=${TALUS_PYTHON:-/usr/bin/python3}

mode=quick
bin="$repo/build/bin"
out=""
jobs=$(nproc)
groups=""
markdown=0
sanitized=0

usage() {
  # The header comment of this file, without the '#'.
  awk 'NR > 1 && !/^#/ { exit } NR > 1 { sub(/^# ?/, ""); print }' "${BASH_SOURCE[0]}"
  cat <<'EOF'
Options:
  --ci | --quick | --full   case set and realizations per case (default --quick)
  --sanitized               one realization per case, for ASan/UBSan builds (about ten
                            times slower); CTest adds it to --ci under TALUS_SANITIZE
  --bin DIR                 directory of terrain-gen, block-gen, dda-run (default build/bin)
  --out DIR                 work directory (default out/stress-MODE); its inputs/, cases/
                            and runs/ are rewritten
  --jobs N                  dda-run processes at once, one thread each (default nproc)
  --groups LIST             only these case groups (comma-separated): size, shape,
                            terrain, impact, landing, numerics, analytic, regression
  --markdown                print the tables as Markdown (for docs/benchmarks.md)
Environment: TALUS_PYTHON (default /usr/bin/python3, needs numpy and h5py);
TALUS_SKIP_STRESS=1 makes the script exit 77 at once (CTest reports the test skipped).
EOF
}

while [ $# -gt 0 ]; do
  case $1 in
    --bin|--out|--jobs|--groups)
      [ $# -ge 2 ] || { echo "stress.sh: $1 needs a value (see --help)" >&2; exit 2; } ;;
  esac
  case $1 in
    --ci) mode=ci ;;
    --quick) mode=quick ;;
    --full) mode=full ;;
    --sanitized) sanitized=1 ;;
    --bin) bin=$2; shift ;;
    --out) out=$2; shift ;;
    --jobs) jobs=$2; shift ;;
    --groups) groups=$2; shift ;;
    --markdown) markdown=1 ;;
    -h|--help) usage; exit 0 ;;
    *) echo "stress.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
  shift
done

if [ "${TALUS_SKIP_STRESS:-0}" = 1 ]; then
  echo "stress.sh: skipped (TALUS_SKIP_STRESS=1)"
  exit 77
fi
[ -n "$out" ] || out="$repo/out/stress-$mode"
[[ $jobs =~ ^[1-9][0-9]*$ ]] || { echo "stress.sh: --jobs needs a positive integer" >&2; exit 2; }
for t in terrain-gen block-gen dda-run; do
  [ -x "$bin/$t" ] || { echo "stress.sh: $bin/$t not found (build it, or give --bin DIR)" >&2; exit 2; }
done
"$python" -c 'import h5py, numpy' 2>/dev/null ||
  { echo "stress.sh: $python cannot import h5py and numpy (scripts/install-deps.sh installs them)" >&2; exit 2; }

bin=$(cd "$bin" && pwd)
out=$(realpath -m "$out")
# Paths go into YAML values (--set KEY=VALUE) and JSON strings unquoted.
if [[ $out == *[\"\'\\\[\]\{\},#:]* ]]; then
  echo "stress.sh: --out '$out' has a character YAML values cannot take unquoted; pick another directory" >&2
  exit 2
fi
mkdir -p "$out"
inputs="$out/inputs"
# Only what this script writes is removed: a stale run file or journal would be read as
# this run's result, or make dda-run refuse to start.
rm -rf "$inputs" "$out/cases" "$out/runs"
mkdir -p "$inputs" "$out/cases" "$out/runs"

want_group() { [ -z "$groups" ] || [[ ",$groups," == *",$1,"* ]]; }
for g in ${groups//,/ }; do
  case $g in
    size|shape|terrain|impact|landing|numerics|analytic|regression) ;;
    *) echo "stress.sh: unknown group '$g' in --groups (see --help)" >&2; exit 2 ;;
  esac
done

# ------------------------------------------------------------------ realizations per mode
# n_main: ordinary cases; n_analytic: each analytic configuration; n_costly: cases whose
# realizations cost about a second or more (the rocks of 1280 and 2880 triangles, time
# step 1e-5 s, 12-DOF).
case $mode in
  ci) n_main=8; n_analytic=2; n_costly=1 ;;
  quick) n_main=24; n_analytic=3; n_costly=6 ;;
  full) n_main=200; n_analytic=8; n_costly=40 ;;
esac
if [ $sanitized = 1 ]; then n_main=1; n_analytic=1; n_costly=1; fi

# ------------------------------------------------------------------ inputs
log_step() { echo "stress: $*" >&2; }
tg() { "$bin/terrain-gen" -q "$@"; }
bg() { "$bin/block-gen" -q "$@"; }
py() { "$python" "$tool" "$@"; }

# The reference ground of SPEC §4 (as samples/bench-slope/terrain.yaml), for every
# terrain of the stress cases.
cat > "$inputs/ground.yaml" <<'EOF'
materials:
  - name: ground
    restitution_mean: 0.95
    restitution_sd: 0.05
    restitution_scale: 12
    friction_angle_mean_deg: 10
    friction_coefficient_sd: 0.05
    lateral_tilt_sd_deg: 0
EOF
# The analytic cases' ground: deterministic draws (sd 0, no tilt). The friction angle is
# set per case by a scene override of material 'ground'.
cat > "$inputs/analytic-ground.yaml" <<'EOF'
materials:
  - name: ground
    restitution_mean: 0.9
    restitution_sd: 0
    restitution_scale: 12
    friction_angle_mean_deg: 0
    friction_coefficient_sd: 0
    lateral_tilt_sd_deg: 0
EOF

log_step "terrains"
# Bench slope of SPEC §6 at roughness S1-S3 (R = 1/8, 1/4, 1/2: sigma 0.1, 0.2, 0.4 m).
for level in S1:0.125 S2:0.25 S3:0.5; do
  tg -c "$repo/samples/bench-slope/terrain.yaml" --set roughness.roughness_index="${level#*:}" \
    -o "$inputs/bench-${level%%:*}.h5"
done
# The bench slope ten times larger (20 m cells, 300 m high, 400 m wide) for the 10 m
# wide 1000 m^3 block, with sigma ten times S1-S3.
for level in S1:1 S2:2 S3:4; do
  tg -c "$inputs/ground.yaml" --set name=big-bench --set synthetic.kind=profile \
    --set synthetic.cell_size=20 --set synthetic.width=400 \
    --set 'synthetic.profile=[[0,300],[60,240],[80,240],[140,180],[160,180],[220,120],[240,120],[360,0],[600,0]]' \
    --set roughness.sigma="${level#*:}" -o "$inputs/big-${level%%:*}.h5"
done
# Planes 60 m long, 40 m wide, 2 m cells: smooth, and rough at S2.
plane_angles=(10 20 30 45 60)
for a in "${plane_angles[@]}" 0; do
  tg -c "$inputs/ground.yaml" --set name="plane-$a" --set synthetic.kind=plane \
    --set synthetic.slope_angle_deg="$a" --set synthetic.length=60 -o "$inputs/plane-$a-smooth.h5"
  tg -c "$inputs/ground.yaml" --set name="plane-$a" --set synthetic.kind=plane \
    --set synthetic.slope_angle_deg="$a" --set synthetic.length=60 --set roughness.roughness_index=0.25 \
    -o "$inputs/plane-$a-rough.h5"
done
# A cliff: 20 m wall over 0.5 m (87 deg between the 1 m grid points) below a plateau,
# above a talus slope and a flat run-out.
for r in smooth:~ rough:0.2; do
  tg -c "$inputs/ground.yaml" --set name=cliff --set synthetic.kind=profile --set synthetic.cell_size=1 \
    --set synthetic.width=30 --set 'synthetic.profile=[[0,40],[8,40],[8.5,20],[40,0],[70,0]]' \
    --set roughness.sigma="${r#*:}" -o "$inputs/cliff-${r%%:*}.h5"
done
# DEMs written as ESRI ASCII: a 35 deg slope with 3 % of its points raised by 1-3 m
# (one-cell spikes), and terraces with 1-2 m steps dropping within one 0.25 m cell.
py dem-spikes "$inputs/spikes.asc"
tg -c "$inputs/ground.yaml" "$inputs/spikes.asc" -o "$inputs/dem-spikes.h5"
# The same slope with 8 % of its points raised: spikes a thin block can fall across.
py dem-spikes "$inputs/spikes8.asc" --fraction 0.08
tg -c "$inputs/ground.yaml" "$inputs/spikes8.asc" -o "$inputs/dem-spikes8.h5"
py dem-steps "$inputs/steps.asc"
tg -c "$inputs/ground.yaml" "$inputs/steps.asc" -o "$inputs/dem-steps.h5"
# Analytic planes: 30 deg, 1 m cells, 40 x 10 m (configs/terrain/plane.yaml), each cell
# cut, and a TIN of the same plane with irregular triangles (the OBJ is named after the
# material it takes).
for cut in alternating random fixed; do
  tg -c "$inputs/analytic-ground.yaml" --set name=analytic-plane --set triangulation=$cut \
    --set synthetic.kind=plane --set synthetic.cell_size=1 --set synthetic.width=10 \
    --set synthetic.length=40 --set synthetic.slope_angle_deg=30 -o "$inputs/analytic-$cut.h5"
done
# The rolling and facet-impact cases' plane: 20 deg, 1 m cells, 40 x 24 m (blocks start
# near y = 12, far from the open side edges).
tg -c "$inputs/analytic-ground.yaml" --set name=analytic-plane20 --set synthetic.kind=plane \
  --set synthetic.cell_size=1 --set synthetic.width=24 --set synthetic.length=40 \
  --set synthetic.slope_angle_deg=20 -o "$inputs/analytic-plane20.h5"
mkdir -p "$inputs/tin"
py tin-plane-obj "$inputs/tin/ground.obj" --angle 30 --length 40 --width 10 --cell 1
tg -c "$inputs/analytic-ground.yaml" --set source=tin --set tin.mode=keep "$inputs/tin/ground.obj" \
  -o "$inputs/analytic-tin.h5"

log_step "blocks"
# Cubes of 1e-3 ... 1000 m^3 (edges 0.1 ... 10 m).
cube_volumes=(0.001 0.01 0.1 1 10 1000)
{
  echo "blocks:"
  for v in "${cube_volumes[@]}"; do echo "  - {name: cube-$v, solid: cube, volume: $v}"; done
} > "$inputs/cubes.yaml"
bg -c "$inputs/cubes.yaml" -o "$inputs/cubes.h5"
# Elongated, flat and concave shapes and the Platonic solids, about 1 m^3 each
# (rock.obj: a noisy, dented icosphere written by stress_tool.py).
py rock-obj "$inputs/rock.obj"
cat > "$inputs/shapes.yaml" <<'EOF'
blocks:
  - {name: needle, solid: box, dimensions: [5, 0.1, 0.1]}
  - {name: slab, solid: box, dimensions: [2, 1, 0.5]}
  - {name: plate, solid: box, dimensions: [2, 2, 0.1]}
  - {name: thin-plate, solid: box, dimensions: [2, 2, 0.05]}
  - {name: rock-obj, mesh: rock.obj, volume: 1}
  - {name: rock-ellipsoid, solid: ellipsoid, dimensions: [1.6, 1.2, 0.9], resolution: 12, roughness: 0.12,
     volume: 1, seed: 4}
  - {name: tetrahedron, solid: tetrahedron, volume: 1}
  - {name: cube, solid: cube, volume: 1}
  - {name: octahedron, solid: octahedron, volume: 1}
  - {name: dodecahedron, solid: dodecahedron, volume: 1}
  - {name: icosahedron, solid: icosahedron, volume: 1}
EOF
# block-gen reads mesh paths relative to its working directory.
(cd "$inputs" && bg -c shapes.yaml -o shapes.h5)
# Sphere-like blocks (icospheres of 5120 and 1280 triangles) and the icosahedron, 1 m^3,
# for the rolling and facet-impact cases.
py sphere-obj "$inputs/sphere5120.obj" --levels 4
py sphere-obj "$inputs/sphere1280.obj" --levels 3
cat > "$inputs/spheres.yaml" <<'EOF'
blocks:
  - {name: sphere5120, mesh: sphere5120.obj, volume: 1}
  - {name: sphere1280, mesh: sphere1280.obj, volume: 1}
  - {name: icosahedron, solid: icosahedron, volume: 1}
EOF
(cd "$inputs" && bg -c spheres.yaml -o spheres.h5)
# R1-R4 of SPEC §6: the library every terrain and numerics case cycles through.
bg -c "$repo/samples/blocks/platonic.yaml" -o "$inputs/platonic.h5"

# The base scene; each case overrides it with --set.
cat > "$inputs/scene.yaml" <<'EOF'
schema_version: "1.0"
terrain: none
block_file: none
block_selection: cycle     # realization i takes block i mod B: the cases' repro indices stay put
release:
  kind: point
  points: [[1, 20]]
  height: 2.5
  orientation: random
realizations: 1
seed: 1
EOF

# ------------------------------------------------------------------ cases
ncase=0
# queue GROUP NAME REALIZATIONS [--analytic JSON] KEY=VALUE...: one dda-run of the base
# scene with these settings. The seed is a hash of GROUP/NAME, so adding or removing a
# case changes no other case's draws.
queue() {
  local group=$1 name=$2 n=$3
  shift 3
  local analytic=null
  if [ "${1:-}" = --analytic ]; then analytic=$2; shift 2; fi
  want_group "$group" || return 0
  [ "$n" -gt 0 ] || return 0
  ncase=$((ncase + 1))
  local id seed
  id=$(printf '%03d' "$ncase")
  seed=$(printf '%s' "$group/$name" | cksum | cut -d' ' -f1)
  mkdir -p "$out/runs/$group"
  {
    for kv in "$@" "realizations=$n" "seed=$seed"; do printf -- '--set\n%s\n' "$kv"; done
  } > "$out/cases/$id.args"
  local run="$out/runs/$group/$name.h5"
  printf '{"id": "%s", "group": "%s", "name": "%s", "realizations": %d, "seed": %s, "run": "%s", "analytic": %s}\n' \
    "$id" "$group" "$name" "$n" "$seed" "$run" "$analytic" > "$out/cases/$id.json"
  echo "$run" > "$out/cases/$id.run"
}
I="$inputs"
line_bench='release.points=[[1,4],[1,36]]'

# --- size: cubes of 1e-3 ... 10 m^3 on the bench slope, 1000 m^3 on the big one, S1-S3.
case $mode in
  ci) size_volumes=("${cube_volumes[@]}"); size_levels=(S2) ;;
  *) size_volumes=("${cube_volumes[@]}"); size_levels=(S1 S2 S3) ;;
esac
for v in "${size_volumes[@]}"; do
  for s in "${size_levels[@]}"; do
    case $v in
      1000) queue size "cube-$v-$s" "$n_main" terrain="$I/big-$s.h5" block_file="$I/cubes.h5" "blocks=[cube-$v]" \
              release.kind=line 'release.points=[[10,40],[10,360]]' release.height=25 ;;
      10) queue size "cube-$v-$s" "$n_main" terrain="$I/bench-$s.h5" block_file="$I/cubes.h5" "blocks=[cube-$v]" \
            release.kind=line "$line_bench" release.height=5 ;;
      *) queue size "cube-$v-$s" "$n_main" terrain="$I/bench-$s.h5" block_file="$I/cubes.h5" "blocks=[cube-$v]" \
           release.kind=line "$line_bench" release.height=2.5 ;;
    esac
  done
done

# --- shape: elongated, flat, concave and Platonic blocks on the bench slope.
case $mode in
  ci) shapes=(needle plate rock-obj dodecahedron); shape_levels=(S2) ;;
  quick) shapes=(needle slab plate rock-obj rock-ellipsoid tetrahedron octahedron dodecahedron icosahedron)
         shape_levels=(S2) ;;
  full) shapes=(needle slab plate rock-obj rock-ellipsoid tetrahedron octahedron dodecahedron icosahedron)
        shape_levels=(S1 S2 S3) ;;
esac
for b in "${shapes[@]}"; do
  for s in "${shape_levels[@]}"; do
    # The needle's circumscribed radius is 2.5 m: release it higher, and 3 m inside the
    # terrain's open upper edge (x = 0): a terrain has no side walls, and a 5 m needle
    # released 1 m from that edge can swing below the surface from outside the domain.
    h=2.5; where=$line_bench
    [ "$b" = needle ] && { h=3.5; where='release.points=[[3,4],[3,36]]'; }
    n=$n_main; [[ $b == rock-* ]] && n=$n_costly
    queue shape "$b-$s" "$n" terrain="$I/bench-$s.h5" block_file="$I/shapes.h5" "blocks=[$b]" \
      release.kind=line "$where" release.height=$h
  done
done

# --- terrain: R1-R4 on planes, a cliff, a spiky DEM, a stepped DEM.
case $mode in
  ci) terrain_planes=(30-smooth 60-rough); terrain_others=(cliff-rough spikes steps) ;;
  *) terrain_planes=(); for a in "${plane_angles[@]}"; do terrain_planes+=("$a-smooth" "$a-rough"); done
     terrain_others=(cliff-smooth cliff-rough spikes steps) ;;
esac
for p in "${terrain_planes[@]}"; do
  queue terrain "plane-$p" "$n_main" terrain="$I/plane-$p.h5" block_file="$I/platonic.h5" \
    release.kind=line 'release.points=[[3,4],[3,36]]'
done
for t in "${terrain_others[@]}"; do
  case $t in
    # Released over the plateau, 1 m before its edge, thrown at 5 m/s towards the wall.
    cliff-*) queue terrain "$t" "$n_main" terrain="$I/$t.h5" block_file="$I/platonic.h5" \
               release.kind=line 'release.points=[[7,3],[7,27]]' 'release.velocity=[5,0,0]' ;;
    spikes) queue terrain dem-spikes "$n_main" terrain="$I/dem-spikes.h5" block_file="$I/platonic.h5" \
              release.kind=line 'release.points=[[2,3],[2,27]]' ;;
    steps) queue terrain dem-steps "$n_main" terrain="$I/dem-steps.h5" block_file="$I/platonic.h5" \
             release.kind=line 'release.points=[[1,3],[1,17]]' 'release.velocity=[3,0,0]' ;;
  esac
done

# Thin blocks (a 2 x 2 x 0.05 m plate, a 5 x 0.1 x 0.1 m needle), cubes of 1e-3, 1 and
# 1000 m^3 and the scanned rock on the densely spiked DEM, the terraces and the cliff: no
# terrain feature may pass into a block (docs/dda.md, Detection), checked at every step.
case $mode in
  ci) impale_terrains=(spikes8); impale_sets=(thin) ;;
  *) impale_terrains=(spikes8 steps cliff-rough); impale_sets=(thin cubes rock) ;;
esac
for t in "${impale_terrains[@]}"; do
  case $t in
    spikes8) ground="$I/dem-spikes8.h5"; where=('release.points=[[3,4],[3,26]]') ;;
    steps) ground="$I/dem-steps.h5"; where=('release.points=[[3,4],[3,16]]' 'release.velocity=[3,0,0]') ;;
    cliff-rough) ground="$I/cliff-rough.h5"; where=('release.points=[[6,4],[6,26]]' 'release.velocity=[5,0,0]') ;;
  esac
  for set in "${impale_sets[@]}"; do
    case $set in
      thin) n=$n_main; what=(block_file="$I/shapes.h5" 'blocks=[thin-plate,needle]' release.height=3.5) ;;
      # The 10 m cube needs its radius (8.7 m) between it and the terrain's open edges.
      cubes) n=$n_main; what=(block_file="$I/cubes.h5" 'blocks=[cube-0.001,cube-1,cube-1000]' release.height=9
                              'release.points=[[10,9.5],[10,10.5]]') ;;
      rock) n=$n_costly; what=(block_file="$I/shapes.h5" 'blocks=[rock-obj]' release.height=2.5) ;;
    esac
    queue terrain "$set-$t" "$n" terrain="$ground" release.kind=line "${where[@]}" "${what[@]}"
  done
done

# --- impact: 50 m/s onto the 60 deg plane, falling vertically and along the normal.
impact_point='release.points=[[20,10],[20,30]]'
queue impact impact50-vertical "$n_main" terrain="$I/plane-60-rough.h5" block_file="$I/platonic.h5" \
  release.kind=line "$impact_point" 'release.velocity=[0,0,-50]'
if [ $mode != ci ]; then
  queue impact impact50-normal "$n_main" terrain="$I/plane-60-rough.h5" block_file="$I/platonic.h5" \
    release.kind=line "$impact_point" 'release.velocity=[-43.30127018922193,0,-25]'
  queue impact impact50-smooth "$n_main" terrain="$I/plane-60-smooth.h5" block_file="$I/platonic.h5" \
    release.kind=line "$impact_point" 'release.velocity=[0,0,-50]'
  queue impact impact50-shapes "$n_main" terrain="$I/plane-60-rough.h5" block_file="$I/shapes.h5" \
    'blocks=[needle,plate,rock-obj]' release.kind=line "$impact_point" 'release.velocity=[0,0,-50]' release.height=3.5
fi

# --- landing: fixed orientations with a vertex or an edge pointing into the ground
# (against its normal), dropped 5 m on the smooth flat plane and on the smooth 30 deg plane.
# The yaw turns the block about the ground normal, keeping the feature down.
case $mode in
  ci) landing_blocks=(cube dodecahedron); landing_angles=(30); landing_yaws=(20) ;;
  quick) landing_blocks=(tetrahedron cube octahedron dodecahedron icosahedron); landing_angles=(0 30)
         landing_yaws=(20) ;;
  full) landing_blocks=(tetrahedron cube octahedron dodecahedron icosahedron); landing_angles=(0 30)
        landing_yaws=(0 20 45) ;;
esac
if want_group landing; then
  for b in "${landing_blocks[@]}"; do
    for feature in vertex edge; do
      for a in "${landing_angles[@]}"; do
        for yaw in "${landing_yaws[@]}"; do
          o=$(py orient $feature --angle "$a" --yaw "$yaw" --block-file "$I/shapes.h5" --block "$b")
          queue landing "$b-$feature-$a-yaw$yaw" "$n_main" terrain="$I/plane-$a-smooth.h5" \
            block_file="$I/shapes.h5" "blocks=[$b]" release.kind=line 'release.points=[[20,10],[20,30]]' \
            release.height=5 release.orientation=fixed "release.orientation_deg=$o"
        done
      done
    done
  done
fi

# --- numerics: contact stiffness and time step over their range, for R1-R4 (1 m^3) on the
# bench slope S2, the 1e-3 m^3 cube on the same slope and (stiffness only) the 1000 m^3
# cube on the big slope S2: a fixed stiffness in N/m means very different springs for
# 2.8 kg and 2.8e6 kg. Each entry is a KEY=VALUE list for dda-run (comma-separated): edit
# these lists to sweep another stiffness setting (e.g. a relative one) the engine may offer.
# The contact stiffness is set relative to the block (penalty_omega, docs/dda.md: its
# range is [3, 300]); an absolute penalty_stiffness is accepted only where it gives the
# block an Ω in that range, so the absolute values are swept for the 1 m^3 blocks only.
stiffness_sweep=(engine.penalty_omega=3 engine.penalty_omega=5 engine.penalty_omega=80 engine.penalty_omega=300)
absolute_sweep=(engine.penalty_stiffness=1e11 engine.penalty_stiffness=1e12 engine.penalty_stiffness=1e13
                engine.penalty_stiffness=1e14)
# The step limit keeps 35 s of simulated time (the default 35 000 steps of 1 ms) at every
# step below 1 ms.
time_step_sweep=(engine.time_step=1e-5,engine.max_steps=3500000 engine.time_step=1e-4,engine.max_steps=350000
                 engine.time_step=1e-3 engine.time_step=1e-2)
numerics_subjects=(R1-R4 cube-0.001 cube-1000)
if [ $mode = ci ]; then
  stiffness_sweep=(engine.penalty_omega=3 engine.penalty_omega=300)
  absolute_sweep=(engine.penalty_stiffness=1e11)
  time_step_sweep=(engine.time_step=1e-2)
  numerics_subjects=(R1-R4 cube-0.001)
fi
for subject in "${numerics_subjects[@]}"; do
  case $subject in
    R1-R4) where=(terrain="$I/bench-S2.h5" block_file="$I/platonic.h5" release.kind=line "$line_bench") ;;
    cube-0.001) where=(terrain="$I/bench-S2.h5" block_file="$I/cubes.h5" "blocks=[$subject]" release.kind=line
                       "$line_bench") ;;
    cube-1000) where=(terrain="$I/big-S2.h5" block_file="$I/cubes.h5" "blocks=[$subject]" release.kind=line
                      'release.points=[[10,40],[10,360]]' release.height=25) ;;
  esac
  entries=("${stiffness_sweep[@]}")
  [ "$subject" = R1-R4 ] && entries+=("${absolute_sweep[@]}")
  [ "$subject" != cube-1000 ] && entries+=("${time_step_sweep[@]}")
  for entry in "${entries[@]}"; do
    IFS=, read -r -a kvs <<< "$entry"
    name=$(printf '%s' "${kvs[0]#engine.}" | tr '=' '-')
    n=$n_main
    [[ $entry == *time_step=1e-5* ]] && n=$n_costly
    queue numerics "$subject-$name" "$n" "${where[@]}" "${kvs[@]}"
  done
done
# The 12-DOF path (strains) on the same slope.
if [ $mode != ci ]; then
  queue numerics dof-full12 "$n_costly" terrain="$I/bench-S2.h5" block_file="$I/platonic.h5" \
    release.kind=line "$line_bench" engine.dof=full12
fi

# --- analytic: the 1 m^3 cube on the smooth 30 deg plane (docs/dda.md, SPEC §7).
# Releasing a block at rest: a dda-run that has release.height_reference measures the
# height from the block's lowest point (0 = touching); otherwise the centroid is put
# (a/2)/cos(theta) + 1e-6 m above the ground, which touches the plane when the cube lies
# flat on it (dda-run may refuse that height: the case then reports the refusal).
theta=30
half_edge=0.5
if "$bin/dda-run" --print-config | grep 'height_reference' > /dev/null; then  # grep -q would stop reading: SIGPIPE under pipefail
  rest_release=(release.height_reference=lowest_point release.height=1e-6)
else
  h=$(awk -v a=$half_edge -v t=$theta 'BEGIN { printf "%.17g", a / cos(t * atan2(0, -1) / 180) + 1e-6 }')
  rest_release=("release.height=$h")
fi
case $mode in
  ci) slide_yaws=(0 45); slide_cuts=(alternating); slide_mus=(0 0.2); stick_yaws=(0); analytic_dofs=(rigid6)
      roll_spheres=(sphere5120); roll_yaws=(0) ;;
  quick) slide_yaws=(0 30 45 60 90); slide_cuts=(alternating random fixed); slide_mus=(0 0.2); stick_yaws=(0 45)
         analytic_dofs=(rigid6); roll_spheres=(sphere5120 sphere1280); roll_yaws=(0 45) ;;
  full) slide_yaws=(0 15 30 45 60 75 90); slide_cuts=(alternating random fixed); slide_mus=(0 0.2)
        stick_yaws=(0 20 45 70); analytic_dofs=(rigid6 full12); roll_spheres=(sphere5120 sphere1280)
        roll_yaws=(0 30 60) ;;
esac
# Release line across the plane at an angle to the lattice: each realization starts at
# another offset from the node lines, and the cube slides across node lines (x) and
# straddles them (y).
slide_line='release.points=[[10.3,2.2],[11.7,7.9]]'
atan_deg() { awk -v m="$1" 'BEGIN { printf "%.17g", atan2(m, 1) * 180 / atan2(0, -1) }'; }
# The rolling case of SPHERE at YAW (deg), below: sets roll_analytic (its analytic check)
# and roll_settings (its scene settings).
roll_case() {
  local sphere=$1 yaw=$2 target
  # Targets: within 2 % over 3 s for the 5120-triangle sphere, 5 % for the 1280-triangle
  # one, whose vertex contacts lie on the smooth surface the vertices sample
  # (smooth_turn_deg 40, docs/dda.md "Smooth surface"; measured within 0.3 % at both).
  case $sphere in sphere5120) target=0.02 ;; *) target=0.05 ;; esac
  # Rolling resistance 0.1 (the default, set here so the case stays what it checks): a
  # ball rolls with (5/7) g (sin t - 0.1 cos t), the check's "mu" being (5/7)·0.1.
  roll_analytic="{\"kind\": \"slide\", \"angle\": 20, \"mu\": 0.07142857142857142, \"rolling\": 0.7142857142857143, \"target\": $target}"
  roll_settings=(terrain="$I/analytic-plane20.h5" block_file="$I/spheres.h5" "blocks=[$sphere]"
    "materials=[{name: ground, friction_angle_mean_deg: $(atan_deg 0.4)}]"
    release.kind=line 'release.points=[[10.3,10.2],[11.7,13.8]]' release.height_reference=lowest_point
    release.height=1e-6 release.orientation=fixed "release.orientation_deg=[$yaw,17,5]" stochastic.roughness=false
    stochastic.restitution=false stochastic.friction=false stochastic.lateral_tilt=false
    engine.time_step=1e-3 engine.max_time=3 engine.smooth_turn_deg=40 engine.rolling_resistance=0.1)
}
if want_group analytic; then
  # Both DOF paths in --full: the 12-DOF path adds the block's strains.
  for dof in "${analytic_dofs[@]}"; do
    sfx=""; [ "$dof" = rigid6 ] || sfx="-$dof"
    for cut in "${slide_cuts[@]}"; do
      for mu in "${slide_mus[@]}"; do
        for yaw in "${slide_yaws[@]}"; do
          o=$(py orient slope-face --angle $theta --yaw "$yaw")
          queue analytic "slide-$cut-mu$mu-yaw$yaw$sfx" "$n_analytic" \
            --analytic "{\"kind\": \"slide\", \"angle\": $theta, \"mu\": $mu, \"target\": 1e-3, \"from_rest\": true}" \
            terrain="$I/analytic-$cut.h5" block_file="$I/cubes.h5" "blocks=[cube-1]" \
            "materials=[{name: ground, friction_angle_mean_deg: $(atan_deg "$mu")}]" \
            release.kind=line "$slide_line" "${rest_release[@]}" release.orientation=fixed \
            "release.orientation_deg=$o" stochastic.roughness=false stochastic.restitution=false \
            stochastic.friction=false stochastic.lateral_tilt=false engine.time_step=1e-3 engine.max_steps=1000 \
            engine.dof="$dof"
        done
      done
    done
    # Frictionless slide after the smallest drop dda-run accepts today (centroid 1 mm above
    # the circumscribed radius), with the restitution law off: no force has a component
    # along a frictionless plane, so the along-slope distance is g sin(theta) T^2 / 2 however
    # the cube bounces; T = 1 s, the simulated-time limit.
    for cut in "${slide_cuts[@]}"; do
      for yaw in "${slide_yaws[@]}"; do
        [ $mode = ci ] && [ "$yaw" != 0 ] && continue
        o=$(py orient slope-face --angle $theta --yaw "$yaw")
        queue analytic "slide-drop-$cut-mu0-yaw$yaw$sfx" "$n_analytic" \
          --analytic "{\"kind\": \"slide\", \"angle\": $theta, \"mu\": 0, \"target\": 1e-3}" \
          terrain="$I/analytic-$cut.h5" block_file="$I/cubes.h5" "blocks=[cube-1]" \
          "materials=[{name: ground, friction_angle_mean_deg: 0}]" \
          release.kind=line "$slide_line" release.height=0.8670254037844386 release.orientation=fixed \
          "release.orientation_deg=$o" stochastic.roughness=false stochastic.restitution=false \
          stochastic.friction=false stochastic.lateral_tilt=false engine.restitution=off \
          engine.time_step=1e-3 engine.max_time=1 engine.dof="$dof"
      done
    done
    # Landing and sticking: mu = 0.6 > tan 30 deg. Dropped face-down (centroid 1 cm above
    # the circumscribed radius: 0.30 m above touching; it lands at 2.4 m/s, 1.2 m/s of it
    # along the slope) on a ground of R_v = 0.5 (on the analytic ground's 0.9 it leaves
    # along the normal at 0.86 of its approach, lands lower down faster and tumbles off,
    # as such an elastic ground lets it: 9 of 16 left the plane), and may slide or tip
    # before it stops: sliding decelerates at only
    # g (mu cos 30 - sin 30) = 0.19 m/s^2), run 20 000 steps of at most 1 ms (about 20 s:
    # steps are cut at impacts) with the rest ending off (rest_kinetic_energy 0) and the
    # centroid sampled every 10 ms; the drift is the largest distance from the final
    # position over the last 5 s.
    for terrain in alternating tin; do
      for yaw in "${stick_yaws[@]}"; do
        o=$(py orient slope-face --angle $theta --yaw "$yaw")
        queue analytic "stick-$terrain-yaw$yaw$sfx" "$n_analytic" \
          --analytic '{"kind": "stick", "window": 5, "target": 1e-6}' \
          terrain="$I/analytic-$terrain.h5" block_file="$I/cubes.h5" "blocks=[cube-1]" \
          "materials=[{name: ground, friction_angle_mean_deg: $(atan_deg 0.6), restitution_mean: 0.5}]" \
          release.kind=line "$slide_line" release.height=0.8760254037844386 release.orientation=fixed \
          "release.orientation_deg=$o" stochastic.roughness=false stochastic.restitution=false \
          stochastic.friction=false stochastic.lateral_tilt=false engine.time_step=1e-3 engine.max_steps=20000 \
          engine.rest_kinetic_energy=0 engine.trajectory_interval=0.01 engine.dof="$dof"
      done
    done
  done
  # Rolling: a sphere-like block (icosphere of 5120 and 1280 triangles, 1 m^3) released at
  # rest on a 20 deg plane with friction enough to roll (mu = 0.4 > 2/7 tan 20 deg), the
  # restitution law on (R_v = 0.9): distance after T s against the sphere's
  # a = (5/7) g (sin(theta) - mu_r cos(theta)), mu_r = 0.1. Its vertex contacts lie on the smooth surface the vertices
  # sample (smooth_turn_deg 40, docs/dda.md): the 5120-triangle block must roll within
  # 2 %, the 1280-triangle one within 5 %.
  for sphere in "${roll_spheres[@]}"; do
    for yaw in "${roll_yaws[@]}"; do
      roll_case "$sphere" "$yaw"
      queue analytic "roll-$sphere-yaw$yaw" "$n_analytic" --analytic "$roll_analytic" "${roll_settings[@]}"
    done
  done
  # Facet impacts: an icosahedron launched down the 20 deg plane at 3.2 m/s tumbles from
  # face to face; the share of kinetic energy each facet impact takes (from the mechanical
  # energy sampled every 1 ms) against the perfectly plastic pivot of a rigid icosahedron,
  # 1 - ((J + m r^2 cos b) / (J + m r^2))^2 = 0.331 (b = 41.8 deg between face normals,
  # r the midradius): within 0.1 of it. The measure is the median over all the case's
  # impacts, and single realizations scatter from 0.19 to 0.37: 8 realizations (300-400
  # impacts, about a second) in every mode, so that the median is a statistic and not the
  # luck of two tumbles.
  if [ ${#roll_spheres[@]} -gt 0 ]; then
    queue analytic "facet-icosahedron" 8 \
      --analytic '{"kind": "facet", "plastic_pivot_loss": 0.331, "target": 0.1}' \
      terrain="$I/analytic-plane20.h5" block_file="$I/spheres.h5" "blocks=[icosahedron]" \
      "materials=[{name: ground, friction_angle_mean_deg: 31}]" release.kind=line \
      'release.points=[[5.3,10.2],[6.7,13.8]]' release.height_reference=lowest_point release.height=0.02 \
      'release.velocity=[3,0,-1.09]' stochastic.roughness=false stochastic.restitution=false \
      stochastic.friction=false stochastic.lateral_tilt=false engine.trajectory_interval=0.001
  fi
fi

# --- regression: single realizations of the full suite that once ended in a numerical
# failure or broke an invariant, re-run in every mode (dda-run --shard K/N runs
# realization K of the case's N, with the case's own seed, the hash of its original
# GROUP/NAME). Each line: original group/name, realization, realizations of the case.
queue_realization() {
  local origin=$1 k=$2 total=$3
  shift 3
  local analytic=null
  if [ "${1:-}" = --analytic ]; then analytic=$2; shift 2; fi
  want_group regression || return 0
  ncase=$((ncase + 1))
  local id seed name
  id=$(printf '%03d' "$ncase")
  seed=$(printf '%s' "$origin" | cksum | cut -d' ' -f1)
  name="${origin#*/}-$k"
  mkdir -p "$out/runs/regression"
  {
    for kv in "$@" "realizations=$total" "seed=$seed"; do printf -- '--set\n%s\n' "$kv"; done
    printf -- '--shard\n%s/%s\n' "$k" "$total"
  } > "$out/cases/$id.args"
  local run="$out/runs/regression/$name.h5"
  printf '{"id": "%s", "group": "regression", "name": "%s", "realizations": 1, "seed": %s, "run": "%s", "analytic": %s}\n' \
    "$id" "$name" "$seed" "$run" "$analytic" > "$out/cases/$id.json"
  echo "$run" > "$out/cases/$id.run"
}
# A locked contact's shear spring held 43 J of a 38.9 J gain at rest (the energy limiter
# relaxed only the normal springs).
queue_realization shape/icosahedron-S3 183 200 terrain="$I/bench-S3.h5" block_file="$I/shapes.h5" \
  "blocks=[icosahedron]" release.kind=line "$line_bench" release.height=2.5
# A re-sticking contact was pre-stretched with the force of a transient iterate: 847 J
# in one step of a block at rest, 0.64 J of it left as height.
queue_realization shape/octahedron-S3 96 200 terrain="$I/bench-S3.h5" block_file="$I/shapes.h5" \
  "blocks=[octahedron]" release.kind=line "$line_bench" release.height=2.5
# A cube tipping over the side edge y = 0 of the rough bench slope swung a vertex under
# the terrain's rim and back inside the footprint, 0.49 m under the ground (overlap 0.70 m
# at rest); it now leaves the terrain as it tips over the rim.
queue_realization size/cube-1-S3 136 200 terrain="$I/bench-S3.h5" block_file="$I/cubes.h5" "blocks=[cube-1]" \
  release.kind=line "$line_bench" release.height=2.5
queue_realization terrain/dem-spikes 39 200 terrain="$I/dem-spikes.h5" block_file="$I/platonic.h5" \
  release.kind=line 'release.points=[[2,3],[2,27]]'
# A landing vertex held closed in tension (4.5e7 N) beside a compressed one turned a
# rolling sphere's spin sideways: 17 % of its kinetic energy in one step, 14 % short of
# (5/7) g sin(theta) t^2/2 over 3 s (target 5 % then, 2 % now).
roll_case sphere5120 45
queue_realization analytic/roll-sphere5120-yaw45 0 3 --analytic "$roll_analytic" "${roll_settings[@]}"
# A landing vertex held closed 9e-5 m in tension (1e8 N) beside a compressed one reversed
# a 5.8 rad/s roll in one step and took 96 % of the kinetic energy: 57 % short (target 5 %).
roll_case sphere1280 30
queue_realization analytic/roll-sphere1280-yaw30 7 8 --analytic "$roll_analytic" "${roll_settings[@]}"

[ $ncase -gt 0 ] || { echo "stress.sh: no case selected (--groups '$groups')" >&2; exit 2; }

# ------------------------------------------------------------------ run
# One dda-run process per case (one thread each), --jobs at a time. A case's exit status
# and wall time go next to its settings; a failed or refused run leaves no run file,
# which the report counts as a case error.
run_case() {
  local id=$1 run group name
  run=$(cat "$out/cases/$id.run")
  local args=()
  mapfile -t args < "$out/cases/$id.args"
  # Every step of every case is checked against the physical invariants (run-file column
  # invariant_violations).
  args+=(--set engine.check_invariants=true)
  # Random orientations can put a block into rough ground at its release: such a release
  # is lifted clear of it (a case may still set release.clearance itself, later wins).
  args=(--set release.clearance=lift "${args[@]}")
  local t0 t1 rc=0
  t0=$(date +%s.%N)
  "$bin/dda-run" -c "$inputs/scene.yaml" "${args[@]}" --threads 1 -o "$run" > "$out/cases/$id.log" 2>&1 || rc=$?
  t1=$(date +%s.%N)
  echo "$rc" > "$out/cases/$id.rc"
  awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.2f\n", b - a }' > "$out/cases/$id.seconds"
  group=${run%/*}; group=${group##*/}; name=${run##*/}; name=${name%.h5}
  echo "stress: [$id/$ncase] $group/$name: exit $rc, $(cat "$out/cases/$id.seconds") s" >&2
}

log_step "$ncase cases ($mode), $jobs at a time, output in $out"
# On an interrupt, stop the cases this script started.
trap 'kill $(jobs -p) 2>/dev/null; exit 130' INT TERM
start=$(date +%s)
running=0
for json in "$out"/cases/*.json; do
  id=$(basename "$json" .json)
  run_case "$id" &
  running=$((running + 1))
  if [ $running -ge "$jobs" ]; then
    wait -n
    running=$((running - 1))
  fi
done
wait
elapsed=$(( $(date +%s) - start ))

# ------------------------------------------------------------------ report
version=$("$bin/dda-run" --version 2>&1 | head -1)
label=$mode; [ $sanitized = 1 ] && label="$mode, sanitized"
heading="stress suite ($label; $ncase cases): $version, $(date -u +%Y-%m-%d), nproc $(nproc), jobs $jobs, ${elapsed} s wall"
status=0
if [ $markdown = 1 ]; then
  echo "$heading"; echo
  py report "$out/cases" --markdown | tee "$out/report.md" || status=$?
else
  echo "$heading"
  py report "$out/cases" | tee "$out/report.txt" || status=$?
fi
exit $status
}
