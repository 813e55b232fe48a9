#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Bad-input matrix of the four tools (docs/errors.md).

Every case runs one built tool on a wrong command line, setting or input file in a fresh
copy of a small set of valid inputs and checks what the tools promise for bad input:

  - the documented exit code (2 usage, 3 bad input, 1 runtime failure);
  - exactly one line on standard error, "TOOL: error: ...", naming the file (or the
    --set key) and what is wrong (the case lists the words the line must contain);
  - nothing on standard output;
  - every file of the directory byte-identical afterwards and no file added (no output,
    no temporary, no journal).

A few positive checks follow: every tool's --help example of --set is a valid setting,
and the README's `stats run.h5 -o stats/ --print-table` works with a trailing slash.

Usage: bad_inputs.py --bin BUILD/bin [--keep DIR] [-k SUBSTRING]
"""
import argparse
import hashlib
import os
import re
import shutil
import struct
import subprocess
import sys
import tempfile

TOOLS = ("terrain-gen", "block-gen", "dda-run", "stats", "calibrate")

# --- valid inputs, written once ----------------------------------------------------------

PLANE_YAML = """source: synthetic
synthetic:
  kind: plane
  cell_size: 1
  width: 10
  length: 20
  slope_angle_deg: 35
materials:
  - name: rock
    restitution_mean: 0.8
"""

BLOCKS_YAML = """blocks:
  - name: c
    solid: cube
    volume: 0.5
"""

SCENE_YAML = """terrain: t.h5
block_file: b.h5
release:
  points: [[3.0, 5.0]]
  height: 1.0
engine:
  max_steps: 3000
realizations: 3
seed: 3
outputs:
  chunk: 2
  hazard_cell_size: 2
"""

# A calibration of the plane's ground against three stop points (docs/calibration.md).
CALIBRATE_YAML = """scene: scene.yaml
groups:
  - observed: stops.csv
parameters:
  - {material: rock, parameter: restitution_mean, min: 0.2, max: 0.9}
realizations: 3
particles: 4
generations: 1
plots: false
"""

# The same calibration against published summaries instead of stops (docs/calibration.md,
# "Summary statistics"); calsum-neg.yaml has a negative sd on line 5.
CALSUM_YAML = """scene: scene.yaml
groups:
  - summaries:
      - {statistic: share_above, threshold: 5, value: 0.5, sd: 0.1}
      - {statistic: max, n: 3, value: 12, sd: 0.5}
parameters:
  - {material: rock, parameter: restitution_mean, min: 0.2, max: 0.9}
realizations: 3
particles: 4
generations: 1
plots: false
"""

# A 4 x 3 DEM on a 1 m grid.
DEM_ASC = """ncols 4
nrows 3
xllcorner 0
yllcorner 0
cellsize 1
NODATA_value -9999
3 2 1 0
3 2 1 0
3 2 1 0
"""

CUBE_OBJ = """v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
f 1 3 2
f 1 4 3
f 5 6 7
f 5 7 8
f 1 2 6
f 1 6 5
f 2 3 7
f 2 7 6
f 3 4 8
f 3 8 7
f 4 1 5
f 4 5 8
"""


def write(path, text):
    with open(path, "w") as f:
        f.write(text)


def las_bytes(points, compressed=False):
    """A LAS 1.2 file of point data record format 1 (28-byte records), scale 0.01 m and
    offset 0, holding `points` as (x, y, z, class)."""
    header = bytearray(227)
    header[0:4] = b"LASF"
    header[24:26] = bytes([1, 2])
    struct.pack_into("<HII", header, 94, 227, 227, 0)  # header size, offset to points, VLRs
    header[104] = 1 | (0x80 if compressed else 0)
    struct.pack_into("<HI", header, 105, 28, len(points))
    struct.pack_into("<6d", header, 131, 0.01, 0.01, 0.01, 0.0, 0.0, 0.0)
    records = b"".join(struct.pack("<iiiHBB", round(x * 100), round(y * 100), round(z * 100), 0, 0, c) + bytes(12)
                       for x, y, z, c in points)
    return bytes(header) + records


def make_fixtures(bin_dir, root):
    """Valid inputs every case starts from (built with the tools themselves)."""
    os.makedirs(root)
    write(os.path.join(root, "plane.yaml"), PLANE_YAML)
    write(os.path.join(root, "blocks.yaml"), BLOCKS_YAML)
    write(os.path.join(root, "scene.yaml"), SCENE_YAML)
    write(os.path.join(root, "calibrate.yaml"), CALIBRATE_YAML)
    write(os.path.join(root, "stops.csv"), "x,y\n12,5\n14,5.5\n15,4\n")
    write(os.path.join(root, "one.csv"), "x,y\n12,5\n")
    write(os.path.join(root, "far.csv"), "x,y\n12,5\n14,5.5\n# mapped past the DEM\n515,4\n")
    write(os.path.join(root, "local.csv"), "x,y\n1012,2005\n1014,2005.5\n")
    write(os.path.join(root, "runouts.csv"), "runout\n9\n40\n")
    write(os.path.join(root, "flat.csv"), "runout,lateral\n9,0\n11,0\n")
    write(os.path.join(root, "scaled-q.txt"), "q0 q1 q2 q3\n1 0 0 0\n0 2 0 0\n")
    write(os.path.join(root, "dem.asc"), DEM_ASC)
    write(os.path.join(root, "cube.obj"), CUBE_OBJ)
    # The cube's top face missing: an open surface.
    write(os.path.join(root, "open.obj"), "\n".join(l for l in CUBE_OBJ.splitlines() if l not in ("f 5 6 7", "f 5 7 8")) + "\n")
    write(os.path.join(root, "huge.obj"), re.sub(r"^v (\S+) (\S+) (\S+)$",
                                                  lambda m: "v " + " ".join(f"{float(x) * 1e150:g}" for x in m.groups()),
                                                  CUBE_OBJ, flags=re.M))
    write(os.path.join(root, "cloud.xyz"), "0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 1 1\n")
    write(os.path.join(root, "nan.xyz"), "0 0 0\n1 0 0\nnan 1 0\n0 0 1\n")
    write(os.path.join(root, "two.xyz"), "0 0 0\n1 0 0\n")
    write(os.path.join(root, "empty.obj"), "")
    # One face given twice, the second turned over: a closed mesh of zero volume.
    write(os.path.join(root, "twin.obj"), "v 0 0 0\nv 10 0 0\nv 0 10 0\nf 1 2 3\nf 1 3 2\n")
    write(os.path.join(root, "badindex.ply"), "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n"
          "property float y\nproperty float z\nelement face 4\nproperty list uchar int vertex_indices\n"
          "end_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 -1\n")
    ground = [(0, 0, 0, 2), (1, 0, 0, 2), (0, 1, 0, 2), (1, 1, 0.5, 2), (0.5, 0.5, 3, 5)]
    for name, data in (("ground.las", las_bytes(ground)), ("ground.laz", las_bytes(ground)),
                       ("packed.las", las_bytes(ground, compressed=True)), ("cut.las", las_bytes(ground)[:-30])):
        with open(os.path.join(root, name), "wb") as f:
            f.write(data)
    write(os.path.join(root, "short.csv"), '"X","Y","Z","Intensity"\n0,0,0,1\n1,0\n')
    write(os.path.join(root, "columns.csv"), "Easting,Northing,Height\n0,0,0\n")
    write(os.path.join(root, "notes.txt"), "not a run file\n")
    dem = DEM_ASC.splitlines()
    write(os.path.join(root, "high.asc"), "\n".join(dem[:7] + ["3 2 1e308 0"] + dem[8:]) + "\n")
    write(os.path.join(root, "infdem.asc"), "\n".join(dem[:7] + ["3 2 inf 0"] + dem[8:]) + "\n")
    write(os.path.join(root, "word.asc"), "\n".join(dem[:7] + ["3 2 abc 0"] + dem[8:]) + "\n")
    write(os.path.join(root, "short.asc"), "\n".join(dem[:-1]) + "\n")
    write(os.path.join(root, "vast.asc"), "ncols 100000000\nnrows 100000000\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2 3\n")
    write(os.path.join(root, "far.asc"), DEM_ASC.replace("xllcorner 0", "xllcorner 1e300"))
    # Projected coordinates with a point without data inside: named in the DEM's own
    # coordinates, not the shifted frame the terrain is built in.
    write(os.path.join(root, "hole.asc"), "ncols 5\nnrows 4\nxllcorner 2600000\nyllcorner 1200000\ncellsize 2\n"
          "NODATA_value -9999\n9 8 7 6 5\n9 8 -9999 6 5\n9 8 7 6 5\n9 8 7 6 5\n")
    write(os.path.join(root, "ids.asc"), DEM_ASC.replace("3 2 1 0", "0 0 0 0"))
    write(os.path.join(root, "bad.yaml"), "source: synthetic\nsynthetic: [unclosed\n")
    write(os.path.join(root, "friction.yaml"), PLANE_YAML.replace("restitution_mean: 0.8", "friction_angle_mean_deg: 100"))
    write(os.path.join(root, "restitution.yaml"), PLANE_YAML.replace("0.8", "5"))
    write(os.path.join(root, "sigma.yaml"), PLANE_YAML + "roughness:\n  sigma: 1e300\n")
    write(os.path.join(root, "volume.yaml"), BLOCKS_YAML.replace("0.5", "1e200"))
    write(os.path.join(root, "mesh-block.yaml"), "blocks:\n  - mesh: cube.obj\n")
    write(os.path.join(root, "schema.yaml"), 'schema_version: "9.0"\n' + SCENE_YAML)
    write(os.path.join(root, "outside.yaml"), SCENE_YAML.replace("[[3.0, 5.0]]", "[[300.0, 5.0]]"))
    # A release line as a vector file (docs/dda-run.md, "Release zones and barriers from vector files").
    write(os.path.join(root, "zones.geojson"), '{"type": "FeatureCollection", "features": [{"type": "Feature", '
          '"properties": {"w": -1}, "geometry": {"type": "LineString", "coordinates": [[3, 4], [3, 6]]}}]}\n')
    os.makedirs(os.path.join(root, "sub"))
    write(os.path.join(root, "loop.yaml"), "a: &a [*a]\n")
    write(os.path.join(root, "faces.yaml"), "blocks:\n  - mesh: cube.obj\ninputs:\n  simplify:\n    mode: faces\n    target_faces: -5\n")
    # Values refused after reading (the scene builder, the synthetic slope, the blocks),
    # named by their line here and by their --set key in the cases that set them.
    write(os.path.join(root, "cell.yaml"), PLANE_YAML.replace("cell_size: 1", "cell_size: 3"))
    write(os.path.join(root, "box.yaml"), "blocks:\n  - name: slab\n    solid: box\n    volume: 1\n")
    write(os.path.join(root, "stats-q.yaml"), "plots: false\nquantiles: [0.5, 1.5]\n")
    write(os.path.join(root, "stats-pool.yaml"), "plots: false\npools:\n  - name: both\n    runs: [nope]\n")
    write(os.path.join(root, "bow.yaml"), SCENE_YAML + "stop_zones:\n  - name: bow\n"
          "    polygon: [[1, 1], [5, 5], [5, 1], [1, 5]]\n")
    write(os.path.join(root, "calset.yaml"), CALIBRATE_YAML + "set: [release.height=1e12]\n")
    write(os.path.join(root, "calsum.yaml"), CALSUM_YAML)
    write(os.path.join(root, "calsum-neg.yaml"), CALSUM_YAML.replace("value: 12, sd: 0.5", "value: 12, sd: -0.5"))
    write(os.path.join(root, "hazard.yaml"), SCENE_YAML.replace("hazard_cell_size: 2", "hazard_cell_size: 1.5"))
    with open(os.path.join(root, "garbage.asc"), "wb") as f:
        f.write(b"ncols\x01\x02\xff\xfe" + bytes(range(128, 228)) + b" 4\n")

    def tool(*args):
        r = subprocess.run([os.path.join(bin_dir, args[0])] + list(args[1:]), cwd=root, capture_output=True, text=True)
        if r.returncode != 0:
            sys.exit(f"fixture failed: {' '.join(args)}: {r.stderr.strip()}")

    tool("terrain-gen", "-c", "plane.yaml", "-o", "t.h5")
    tool("block-gen", "-c", "blocks.yaml", "-o", "b.h5")
    tool("dda-run", "-c", "scene.yaml", "--threads", "1", "-o", "run.h5")
    tool("terrain-gen", "-c", "plane.yaml", "--set", "synthetic.slope_angle_deg=30", "-o", "other.h5")
    os.remove(os.path.join(root, "other.xmf"))
    # The plane with local coordinates [1000, 1020] x [2000, 2010] (input ones [0, 20] x [0, 10]).
    tool("terrain-gen", "-c", "plane.yaml", "--set", "origin.mode=given", "--set", "origin.shift=[-1000,-2000,0]",
         "-o", "shifted.h5")
    os.remove(os.path.join(root, "shifted.xmf"))
    os.remove(os.path.join(root, "t.xmf")) if os.path.exists(os.path.join(root, "t.xmf")) else None
    os.symlink("dem.asc", os.path.join(root, "link.asc"))
    os.link(os.path.join(root, "run.h5"), os.path.join(root, "hard.h5"))
    os.makedirs(os.path.join(root, "st"))
    shutil.copy(os.path.join(root, "run.h5"), os.path.join(root, "st", "summary.h5"))


# --- the cases ---------------------------------------------------------------------------
# (tool and arguments, exit code, words the error line must contain)

USAGE, BAD_INPUT, RUNTIME = 2, 3, 1

CASES = [
    # Command lines.
    (["terrain-gen", "--sett", "roughness.sigma=0.2"], USAGE, ["unknown option '--sett'", "did you mean '--set'"]),
    (["block-gen", "cube.obj", "--ouput", "x.h5"], USAGE, ["'--ouput'", "did you mean '--output'"]),
    (["dda-run", "-c", "scene.yaml", "--resum", "-o", "x.h5"], USAGE, ["'--resum'", "did you mean '--resume'"]),
    (["stats", "--set", "plots=false", "run.h5", "-o", "s", "--print-tabel"], USAGE, ["'--print-tabel'", "did you mean '--print-table'"]),
    (["terrain-gen", "dem.asc"], USAGE, ["no output file"]),
    (["block-gen", "cube.obj"], USAGE, ["no output file"]),
    (["dda-run", "-c", "scene.yaml"], USAGE, ["no output file"]),
    (["stats", "--set", "plots=false", "run.h5"], USAGE, ["-o"]),
    (["dda-run", "-c", "scene.yaml", "--threads", "abc", "-o", "x.h5"], USAGE, ["--threads", "abc"]),
    (["dda-run", "-c", "scene.yaml", "--shard", "3/2", "-o", "x.h5"], USAGE, ["3/2"]),
    (["terrain-gen", "dem.asc", "--log-level", "loud", "-o", "x.h5"], USAGE, ["--log-level", "loud"]),
    (["terrain-gen", "dem.asc", "--set", "novalue", "-o", "x.h5"], USAGE, ["--set", "novalue"]),
    (["dda-run", "merge", "-o", "x.h5"], USAGE, ["input"]),
    (["block-gen", "-o", "x.h5"], USAGE, ["nothing to build"]),
    # An output that would overwrite an input, or another output.
    (["terrain-gen", "dem.asc", "-o", "dem.asc"], USAGE, ["-o dem.asc", "the input dem.asc", "never overwrites"]),
    (["terrain-gen", "dem.asc", "-o", "./dem.asc"], USAGE, ["-o ./dem.asc", "the input dem.asc"]),
    (["terrain-gen", "dem.asc", "-o", "sub/../dem.asc"], USAGE, ["-o sub/../dem.asc", "the input dem.asc"]),
    (["terrain-gen", "dem.asc", "-o", "link.asc"], USAGE, ["-o link.asc", "the input dem.asc"]),
    (["terrain-gen", "-c", "plane.yaml", "-o", "plane.yaml"], USAGE, ["-o plane.yaml", "settings file"]),
    (["terrain-gen", "dem.asc", "-o", "x.h5", "--export-mesh", "./dem.asc"], USAGE, ["--export-mesh"]),
    (["terrain-gen", "dem.asc", "--set", "material_raster=ids.asc", "-o", "ids.asc"], USAGE, ["-o ids.asc", "material_raster"]),
    (["terrain-gen", "dem.asc", "--set", "zone_file.file=zones.geojson", "-o", "zones.geojson"], USAGE,
     ["-o zones.geojson", "zone_file.file"]),
    (["terrain-gen", "dem.asc", "-o", "x.h5", "--export-mesh", "x.xmf"], USAGE, ["x.xmf"]),
    (["block-gen", "cube.obj", "-o", "cube.obj"], USAGE, ["-o cube.obj", "the input cube.obj"]),
    (["block-gen", "cube.obj", "-o", "x.h5", "--export-mesh", "./cube.obj"], USAGE, ["--export-mesh", "cube.obj"]),
    (["block-gen", "-c", "mesh-block.yaml", "-o", "cube.obj"], USAGE, ["-o cube.obj", "blocks[0].mesh"]),
    (["block-gen", "-c", "blocks.yaml", "-o", "blocks.yaml"], USAGE, ["-o blocks.yaml"]),
    (["dda-run", "-c", "scene.yaml", "-o", "t.h5"], USAGE, ["-o t.h5", "terrain"]),
    (["dda-run", "-c", "scene.yaml", "-o", "./b.h5"], USAGE, ["-o ./b.h5", "block file"]),
    (["dda-run", "-c", "scene.yaml", "-o", "scene.yaml"], USAGE, ["-o scene.yaml", "settings file"]),
    (["dda-run", "-c", "scene.yaml", "--set", "release={kind: line, file: zones.geojson}", "-o", "zones.geojson"], USAGE,
     ["-o zones.geojson", "vector file (key release.file)"]),
    (["dda-run", "-c", "scene.yaml", "--set", "terrain=sub/../t.h5", "-o", "t.h5"], USAGE, ["-o t.h5", "terrain"]),
    (["dda-run", "merge", "run.h5", "-o", "run.h5"], USAGE, ["-o run.h5", "the input run.h5"]),
    (["dda-run", "merge", "run.h5", "-o", "hard.h5"], USAGE, ["-o hard.h5", "the input run.h5"]),
    (["stats", "--set", "plots=false", "run.h5", "-o", "run.h5"], USAGE, ["-o run.h5", "output directory"]),
    (["stats", "--set", "plots=false", "st/summary.h5", "-o", "st/"], USAGE, ["st/summary.h5"]),
    (["stats", "--set", "plots=false", "run.h5", "-o", "s", "--set", "terrain=s/summary.h5"], USAGE, ["terrain"]),
    # Values out of range or not finite, named where they enter.
    (["terrain-gen", "-c", "friction.yaml", "-o", "x.h5"], BAD_INPUT,
     ["friction.yaml:10", "friction_angle_mean_deg", "[0, 90) deg", "100"]),
    (["terrain-gen", "-c", "restitution.yaml", "-o", "x.h5"], BAD_INPUT, ["restitution.yaml:10", "restitution_mean", "[0, 1]"]),
    (["terrain-gen", "-c", "sigma.yaml", "-o", "x.h5"], BAD_INPUT, ["sigma.yaml:12", "roughness.sigma", "[0, 100] m"]),
    (["terrain-gen", "--set", "roughness.sigma=1e300", "-o", "x.h5"], BAD_INPUT, ["--set roughness.sigma", "[0, 100] m", "1e+300"]),
    (["terrain-gen", "-c", "plane.yaml", "--set", "roughness.sigma=-1", "-o", "x.h5"], BAD_INPUT, ["--set roughness.sigma", "[0, 100] m"]),
    (["terrain-gen", "-c", "plane.yaml", "--set", "roughness.sigma=.nan", "-o", "x.h5"], BAD_INPUT, ["--set roughness.sigma", "finite"]),
    (["terrain-gen", "--set", "materials=[{name: r, restitution_mean: 5}]", "-o", "x.h5"], BAD_INPUT,
     ["--set materials", "restitution_mean", "[0, 1]"]),
    (["terrain-gen", "--set", "synthetic.slope_angle_deg=90", "-o", "x.h5"], BAD_INPUT, ["--set synthetic.slope_angle_deg", "[0, 90) deg"]),
    (["terrain-gen", "--set", "synthetic.cell_size=0", "-o", "x.h5"], BAD_INPUT, ["--set synthetic.cell_size", "(0, 10000] m"]),
    (["terrain-gen", "-c", "plane.yaml", "--set", "roughness.sigam=0.2", "-o", "x.h5"], BAD_INPUT,
     ["--set roughness.sigam", "unknown key", "did you mean 'roughness.sigma'"]),
    (["terrain-gen", "-c", "plane.yaml", "--set", "origin.shift=[0,0,1e300]", "-o", "x.h5"], BAD_INPUT, ["--set origin.shift", "[-1e+09, 1e+09] m"]),
    (["terrain-gen", "high.asc", "-o", "x.h5"], BAD_INPUT, ["high.asc:8", "1e308", "[-1e6, 1e6] m"]),
    (["terrain-gen", "infdem.asc", "-o", "x.h5"], BAD_INPUT, ["infdem.asc:8", "non-finite"]),
    (["terrain-gen", "word.asc", "-o", "x.h5"], BAD_INPUT, ["word.asc:8", "abc"]),
    (["terrain-gen", "short.asc", "-o", "x.h5"], BAD_INPUT, ["short.asc", "too few values"]),
    (["terrain-gen", "vast.asc", "-o", "x.h5"], BAD_INPUT, ["vast.asc:1", "ncols 100000000 x nrows 100000000"]),
    (["terrain-gen", "far.asc", "-o", "x.h5"], BAD_INPUT, ["far.asc", "[-1e9, 1e9] m"]),
    (["terrain-gen", "hole.asc", "-o", "x.h5"], BAD_INPUT, ["hole.asc", "(i=2, j=2) at (x=2600005, y=1200005)", "NODATA"]),
    (["terrain-gen", "huge.obj", "-o", "x.h5"], BAD_INPUT, ["huge.obj", "vertex", "[-1e9, 1e9] m"]),
    (["terrain-gen", "twin.obj", "-o", "x.h5"], BAD_INPUT, ["twin.obj", "triangle 0 and triangle 1", "same three corners"]),
    (["terrain-gen", "missing.asc", "-o", "x.h5"], BAD_INPUT, ["missing.asc"]),
    (["terrain-gen", "ground.laz", "-o", "x.h5"], BAD_INPUT,
     ["ground.laz", "LAZ is compressed", "las2las -i in.laz -o out.las", "pdal translate in.laz out.las"]),
    (["terrain-gen", "packed.las", "-o", "x.h5"], BAD_INPUT, ["packed.las", "compressed (LAZ)", "decompress"]),
    (["terrain-gen", "cut.las", "-o", "x.h5"], BAD_INPUT, ["cut.las", "truncated LAS file", "declares 5 points"]),
    (["terrain-gen", "ground.las", "--set", "tin.las_classes=[9]", "-o", "x.h5"], BAD_INPUT,
     ["ground.las", "no point of class 9", "2 (4 points), 5 (1 point)"]),
    (["terrain-gen", "ground.las", "--set", "tin.las_classes=[256]", "-o", "x.h5"], BAD_INPUT,
     ["tin.las_classes", "256", "0 to 255"]),
    (["terrain-gen", "short.csv", "-o", "x.h5"], BAD_INPUT, ["short.csv", "line 3", "2 columns, expected at least 3"]),
    (["terrain-gen", "columns.csv", "-o", "x.h5"], BAD_INPUT, ["columns.csv", "line 1", "header naming the X, Y and Z"]),
    (["block-gen", "ground.laz", "-o", "x.h5"], BAD_INPUT, ["ground.laz", "LAZ is compressed"]),
    (["terrain-gen", "-c", "missing.yaml", "-o", "x.h5"], BAD_INPUT, ["missing.yaml"]),
    (["terrain-gen", "-c", "bad.yaml", "-o", "x.h5"], BAD_INPUT, ["bad.yaml:", "YAML"]),
    (["block-gen", "huge.obj", "-o", "x.h5"], BAD_INPUT, ["huge.obj", "vertex 1", "[-1e9, 1e9] m"]),
    (["block-gen", "badindex.ply", "-o", "x.h5"], BAD_INPUT,
     ["badindex.ply", "face refers to vertex index -1, but the vertices are numbered 0 to 3"]),
    (["block-gen", "cube.obj", "--set", "inputs.scale=1e150", "-o", "x.h5"], BAD_INPUT, ["--set inputs.scale", "(0, 1e+06]"]),
    (["block-gen", "cube.obj", "--set", "inputs.scale=1e-150", "-o", "x.h5"], BAD_INPUT, ["cube.obj", "block volume", "[1e-06, 1e+06] m^3"]),
    (["block-gen", "--set", "blocks=[{solid: cube, volume: 1e300}]", "-o", "x.h5"], BAD_INPUT,
     ["--set blocks", "volume", "[1e-06, 1e+06] m^3"]),
    (["block-gen", "-c", "volume.yaml", "-o", "x.h5"], BAD_INPUT, ["volume.yaml:4", "blocks[0].volume", "1e+200"]),
    (["block-gen", "-c", "blocks.yaml", "--set", "blocks[0].volume=1e-300", "-o", "x.h5"], BAD_INPUT, ["--set blocks[0].volume", "[1e-06, 1e+06]"]),
    (["block-gen", "-c", "blocks.yaml", "--set", "blocks[0].volume=0", "-o", "x.h5"], BAD_INPUT, ["--set blocks[0].volume"]),
    (["block-gen", "-c", "blocks.yaml", "--set", "blocks[0].volume=-1", "-o", "x.h5"], BAD_INPUT, ["--set blocks[0].volume", "-1"]),
    (["block-gen", "-c", "blocks.yaml", "--set", "blocks[0].volume=.inf", "-o", "x.h5"], BAD_INPUT, ["--set blocks[0].volume", "finite"]),
    (["block-gen", "-c", "blocks.yaml", "--set", "blocks[0].dimensions=[1,1,1e300]", "-o", "x.h5"], BAD_INPUT, ["--set blocks[0].dimensions"]),
    (["block-gen", "-c", "blocks.yaml", "--set", "density=-5", "-o", "x.h5"], BAD_INPUT, ["--set density", "kg/m^3"]),
    (["block-gen", "-c", "blocks.yaml", "--set", "blocks[0].solid=sphere", "-o", "x.h5"], BAD_INPUT, ["--set blocks[0].solid", "sphere", "not one of"]),
    (["block-gen", "open.obj", "-o", "x.h5"], BAD_INPUT, ["open.obj", "inputs.repair.fill_holes"]),
    (["block-gen", "empty.obj", "-o", "x.h5"], BAD_INPUT, ["empty.obj"]),
    (["block-gen", "nan.xyz", "-o", "x.h5"], BAD_INPUT, ["nan.xyz"]),
    (["block-gen", "two.xyz", "-o", "x.h5"], BAD_INPUT, ["two.xyz"]),
    (["block-gen", "missing.obj", "-o", "x.h5"], BAD_INPUT, ["missing.obj"]),
    (["block-gen", "info", "missing.h5"], BAD_INPUT, ["missing.h5"]),
    (["dda-run", "-c", "scene.yaml", "--set", "release.velocity=[1e200,0,0]", "-o", "x.h5"], BAD_INPUT,
     ["--set release.velocity", "[-1000, 1000] m/s", "1e+200"]),
    (["dda-run", "-c", "scene.yaml", "--set", "release.angular_velocity=[0,0,1e9]", "-o", "x.h5"], BAD_INPUT,
     ["--set release.angular_velocity", "rad/s"]),
    (["dda-run", "-c", "scene.yaml", "--set", "release.orientation=list", "--set", "release.orientation_file=scaled-q.txt",
      "-o", "x.h5"], BAD_INPUT, ["scaled-q.txt: line 3", "quaternion norm 2 is not 1"]),
    (["dda-run", "-c", "scene.yaml", "--set", "release.orientation=list", "--set", "release.orientation_file=missing.txt",
      "-o", "x.h5"], BAD_INPUT, ["missing.txt", "cannot open"]),
    (["dda-run", "-c", "scene.yaml", "--set", "release.orientation_file=scaled-q.txt", "-o", "x.h5"], BAD_INPUT,
     ["--set release.orientation_file", "needs release.orientation: list"]),
    (["dda-run", "-c", "scene.yaml", "--set", "materials=[{name: rock, restitution_mean: 5}]", "-o", "x.h5"], BAD_INPUT,
     ["--set materials", "restitution_mean", "[0, 1]"]),
    (["dda-run", "-c", "scene.yaml", "--set", "realizations=0", "-o", "x.h5"], BAD_INPUT, ["--set realizations", "[1, 4294967295]"]),
    (["dda-run", "-c", "scene.yaml", "--set", "outputs.chunk=0", "-o", "x.h5"], BAD_INPUT, ["--set outputs.chunk", "[1, 4294967295]"]),
    (["dda-run", "-c", "scene.yaml", "--set", "unknown.key=1", "-o", "x.h5"], BAD_INPUT, ["--set unknown.key", "unknown key"]),
    (["dda-run", "-c", "scene.yaml", "--set", "terrain=missing.h5", "-o", "x.h5"], BAD_INPUT, ["missing.h5"]),
    (["dda-run", "-c", "scene.yaml", "--set", "terrain=notes.txt", "-o", "x.h5"], BAD_INPUT, ["notes.txt"]),
    (["dda-run", "-c", "scene.yaml", "--set", "block_file=t.h5", "-o", "x.h5"], BAD_INPUT, ["t.h5"]),
    (["dda-run", "-c", "outside.yaml", "-o", "x.h5"], BAD_INPUT,
     [": error: outside.yaml:4: release point (300, 5) is outside the terrain (input coordinates: x in [0, 20], "
      "y in [0, 10])"]),
    (["dda-run", "-c", "scene.yaml", "--set", "release={kind: line, file: nowhere.gpkg}", "-o", "x.h5"], BAD_INPUT,
     ["nowhere.gpkg", "cannot open file"]),
    (["dda-run", "-c", "scene.yaml", "--set", "release={kind: polygon, file: zones.geojson}", "-o", "x.h5"], BAD_INPUT,
     ["zones.geojson", "feature 0 is a Line String, not a Polygon or MultiPolygon"]),
    (["dda-run", "-c", "scene.yaml", "--set", "release={kind: line, file: zones.geojson, weight_field: weight}", "-o",
      "x.h5"], BAD_INPUT, ["zones.geojson", "has no field 'weight'"]),
    (["dda-run", "-c", "scene.yaml", "--set", "release={kind: line, file: zones.geojson, weight_field: w}", "-o",
      "x.h5"], BAD_INPUT, ["zones.geojson", "feature 0 has weight -1"]),
    (["dda-run", "-c", "scene.yaml", "--set", "outputs.barriers=[{file: zones.geojson, layer: fences}]", "-o", "x.h5"],
     BAD_INPUT, ["zones.geojson", "has no layer 'fences'"]),
    (["dda-run", "merge", "t.h5", "-o", "x.h5"], BAD_INPUT, ["t.h5"]),
    (["stats", "--set", "plots=false", "missing.h5", "-o", "s"], BAD_INPUT, ["missing.h5"]),
    (["stats", "--set", "plots=false", "notes.txt", "-o", "s"], BAD_INPUT, ["notes.txt"]),
    (["stats", "--set", "plots=false", "t.h5", "-o", "s"], BAD_INPUT, ["t.h5"]),
    (["stats", "--set", "plots=false", "run.h5", "--set", "unknown=1", "-o", "s"], BAD_INPUT, ["--set unknown", "unknown key"]),
    (["stats", "--set", "plots=false", "run.h5", "-o", "no/such/dir"], RUNTIME, ["no/such"]),
    (["stats", "--set", "plots=false", "run.h5", "--set", "terrain=other.h5", "-o", "s"], BAD_INPUT,
     ["other.h5", "is not the terrain of the run run.h5", "fingerprint"]),
    # stats' values refused after reading: named by the --set key, or the file and line.
    (["stats", "--set", "plots=false", "run.h5", "--set", "quantiles=[0.5, 1.5]", "-o", "s"], BAD_INPUT,
     ["stats: error: --set quantiles: quantiles: 1.5 is not in (0, 1)"]),
    (["stats", "-c", "stats-q.yaml", "run.h5", "-o", "s"], BAD_INPUT,
     ["stats: error: stats-q.yaml:2: quantiles: 1.5 is not in (0, 1)"]),
    (["stats", "--set", "plots=false", "run.h5", "--set", "names=[a, b]", "-o", "s"], BAD_INPUT,
     ["stats: error: --set names: names: 2 names for 1 runs"]),
    (["stats", "-c", "stats-pool.yaml", "run.h5", "-o", "s"], BAD_INPUT,
     ["stats: error: stats-pool.yaml:", "pools: 'both' names run 'nope', which is not among the runs"]),
    # Settings that crash, hang or are silently ignored.
    (["terrain-gen", "-c", "loop.yaml", "-o", "x.h5"], BAD_INPUT, ["loop.yaml:1", "nested more than 64 levels"]),
    (["terrain-gen", "-c", "sub", "-o", "x.h5"], BAD_INPUT, ["sub", "is a directory, not a settings file"]),
    (["terrain-gen", "-c", "plane.yaml", "--set", "synthetic.cell_size=3", "-o", "x.h5"], BAD_INPUT,
     [": error: --set synthetic.cell_size: synthetic slope: length 20 m is not a whole number of cells of cell_size 3 m"]),
    (["dda-run", "-c", "scene.yaml", "--set", "release.height=1e12", "-o", "x.h5"], BAD_INPUT,
     ["--set release.height", "[-10000, 10000] m", "1e+12"]),
    (["dda-run", "-c", "scene.yaml", "--set", "release=", "-o", "x.h5"], BAD_INPUT, ["--set release", "got nothing"]),
    (["dda-run", "-c", "scene.yaml", "--set", "blocks=[NOPE]", "-o", "x.h5"], BAD_INPUT,
     ["--set blocks", "block 'NOPE' is not in the block file b.h5 (it has: c)"]),
    (["calibrate", "-c", "calibrate.yaml", "--set", "groups[0].main_direction_deg=1000", "-o", "c"], BAD_INPUT,
     ["--set groups[0].main_direction_deg", "[-360, 360] deg"]),
    (["block-gen", "-c", "faces.yaml", "-o", "x.h5"], BAD_INPUT, ["faces.yaml:6", "inputs.simplify.target_faces", "[4, 1e+08]", "-5"]),
    (["terrain-gen", "garbage.asc", "-o", "x.h5"], BAD_INPUT, ["garbage.asc:1", "\\x01\\x02\\xff"]),
    (["dda-run", "merge", "run.h5", "run.h5", "-o", "x.h5"], BAD_INPUT, ["run.h5: realization 0 appears twice (also in run.h5; the same file given twice?)"]),
    # Values checked after reading are named where they were given: the --set key, else
    # the file and line (docs/errors.md, "Bad input").
    (["terrain-gen", "-c", "cell.yaml", "-o", "x.h5"], BAD_INPUT,
     [": error: cell.yaml:4: synthetic slope: length 20 m is not a whole number of cells of cell_size 3 m"]),
    (["terrain-gen", "-c", "plane.yaml", "--set", "synthetic.width=7.5", "-o", "x.h5"], BAD_INPUT,
     [": error: --set synthetic.width: synthetic slope: width 7.5 m is not a whole number of cells"]),
    (["terrain-gen", "-c", "plane.yaml", "--set", "roughness.sigma=0.1", "--set", "roughness.roughness_index=0.1",
      "-o", "x.h5"], BAD_INPUT,
     [": error: --set roughness.roughness_index: roughness: give sigma or roughness_index, not both"]),
    (["terrain-gen", "-c", "plane.yaml", "--set", "zones=[{material: mud, polygon: [[0, 0], [1, 0], [1, 1]]}]",
      "-o", "x.h5"], BAD_INPUT, [": error: --set zones: zone 0 (material 'mud'): unknown material 'mud' (known: rock)"]),
    (["terrain-gen", "-c", "plane.yaml", "--set", "crop.xmin=5", "--set", "crop.xmax=1", "-o", "x.h5"], BAD_INPUT,
     [": error: --set crop.xmin: crop: the window [5, 1] x ", "is empty (need xmin < xmax and ymin < ymax)"]),
    (["terrain-gen", "-c", "plane.yaml", "--set", "materials=[{name: a}, {name: a}]", "-o", "x.h5"], BAD_INPUT, [": error: --set materials: materials[1]: duplicate material name 'a'"]),
    (["block-gen", "--set", "blocks=[{solid: box}]", "-o", "x.h5"], BAD_INPUT,
     [": error: --set blocks: blocks[0]: a box needs its edges along x, y, z in dimensions: [a, b, c] (m)"]),
    (["block-gen", "-c", "box.yaml", "-o", "x.h5"], BAD_INPUT,
     [": error: box.yaml:2: blocks[0]: a box needs its edges along x, y, z in dimensions: [a, b, c] (m)"]),
    (["block-gen", "-c", "blocks.yaml", "--set", "blocks[0].solid=ellipsoid", "-o", "x.h5"], BAD_INPUT,
     [": error: --set blocks[0].solid: blocks[0]: an ellipsoid needs its diameters along x, y, z in dimensions"]),
    (["block-gen", "-c", "box.yaml", "--set", "blocks[0].dimensions=[2, 0, 1]", "-o", "x.h5"], BAD_INPUT,
     [": error: --set blocks[0].dimensions: blocks[0]: a box needs its edges", "each > 0, got [2, 0, 1]"]),
    (["block-gen", "cube.obj", "--set", "inputs.repair.max_hole_edges=2", "-o", "x.h5"], BAD_INPUT,
     [": error: --set inputs.repair.max_hole_edges: must be in [3, inf), got 2"]),
    (["block-gen", "cube.obj", "--set", "inputs.beta_deg=200", "-o", "x.h5"], BAD_INPUT,
     [": error: --set inputs.beta_deg: must be in (0, 180) deg, got 200"]),
    (["block-gen", "--set", "blocks=[{solid: ellipsoid, dimensions: [1, 1, 1], resolution: 5000}]", "-o", "x.h5"],
     BAD_INPUT, [": error: --set blocks: blocks[0].resolution: must be in [1, 1000], got 5000"]),
    (["dda-run", "-c", "scene.yaml", "--set", "release.points=[[300, 5]]", "-o", "x.h5"], BAD_INPUT,
     [": error: --set release.points: release point (300, 5) is outside the terrain"]),
    (["dda-run", "-c", "scene.yaml", "--set", "release.kind=polygon", "-o", "x.h5"], BAD_INPUT,
     [": error: --set release.kind: release.kind 'polygon' needs at least 3 points in release.points, got 1"]),
    (["dda-run", "-c", "scene.yaml", "--set", "release.kind=line", "--set", "release.file=zones.geojson", "-o", "x.h5"],
     BAD_INPUT,
     [": error: --set release.file: release: give release.points or release.file, not both"]),
    (["dda-run", "-c", "scene.yaml", "--set", "release.layer=fences", "-o", "x.h5"], BAD_INPUT,
     [": error: --set release.layer: release.layer and release.weight_field need release.file"]),
    (["dda-run", "-c", "scene.yaml", "--set", "release.height_reference=lowest_point", "--set", "release.height=-1",
      "-o", "x.h5"], BAD_INPUT,
     [": error: --set release.height: release.height -1 m is negative: with height_reference lowest_point"]),
    (["dda-run", "-c", "scene.yaml", "--set", "release.height=-2", "-o", "x.h5"], BAD_INPUT,
     [": error: --set release.height: release of realization ", " at (3, 5): block 'c' reaches",
      "into the ground", "raise release.height by at least"]),
    (["dda-run", "-c", "scene.yaml", "--set", "engine.max_step_travel=0", "--set", "engine.min_time_step=0.01", "-o",
      "x.h5"], BAD_INPUT,
     [": error: --set engine.min_time_step: block 'c': engine.time_step = 0.001 s is below min_time_step = 0.01 s"]),
    (["dda-run", "-c", "scene.yaml", "--set", "stop_zones=[{name: z, x_range: [5, 1]}]", "-o", "x.h5"], BAD_INPUT,
     [": error: --set stop_zones: stop zone 'z': x_range must be [x_min, x_max] with x_min < x_max"]),
    (["dda-run", "-c", "bow.yaml", "-o", "x.h5"], BAD_INPUT,
     [": error: bow.yaml:15: stop zone 'bow': polygon crosses itself (edges 1 and 3 meet)"]),
    (["dda-run", "-c", "bow.yaml", "--set", "stop_zones[0].polygon=[[1, 1], [9, 1]]", "-o", "x.h5"], BAD_INPUT,
     [": error: --set stop_zones[0].polygon: stop zone 'bow': polygon needs 3 or more vertices and an area"]),
    (["dda-run", "-c", "scene.yaml", "--set", "outputs.barriers=[{name: fence, line: [[1, 1]]}]", "-o", "x.h5"],
     BAD_INPUT, [": error: --set outputs.barriers: barrier 'fence' needs at least 2 finite vertices in its line"]),
    (["dda-run", "-c", "scene.yaml", "--set", "outputs.hazard_cell_size=1.5", "-o", "x.h5"], BAD_INPUT,
     [": error: --set outputs.hazard_cell_size: outputs.hazard_cell_size 1.5 m is neither a multiple nor a divisor"]),
    (["dda-run", "-c", "hazard.yaml", "-o", "x.h5"], BAD_INPUT,
     [": error: hazard.yaml:12: outputs.hazard_cell_size 1.5 m is neither a multiple nor a divisor"]),
    (["dda-run", "-c", "scene.yaml", "--set", "materials=[{name: scree}]", "-o", "x.h5"], BAD_INPUT,
     [": error: --set materials: material 'scree' is not in the terrain file"]),
    (["dda-run", "-c", "scene.yaml", "--set", "schema_version=2.0", "-o", "x.h5"], BAD_INPUT,
     [": error: --set schema_version: scene schema version 2.0 is not supported (this build reads 1.x)"]),
    (["dda-run", "-c", "scene.yaml", "--set", "engine.penalty_stiffness=1000", "-o", "x.h5"], BAD_INPUT,
     [": error: --set engine.penalty_stiffness: block 'c': engine.penalty_stiffness = 1000 N/m gives this block"]),
    (["dda-run", "-c", "schema.yaml", "-o", "x.h5"], BAD_INPUT, [": error: schema.yaml:1: scene schema version 9.0"]),
    (["calibrate", "-c", "calibrate.yaml", "--set", "set=['release.points=[[300, 5]]']", "-o", "c"], BAD_INPUT,
     [": error: --set set: release.points: release point (300, 5) is outside the terrain"]),
    (["calibrate", "-c", "calset.yaml", "-o", "c"], BAD_INPUT,
     [": error: calset.yaml:10: set release.height: must be in [-10000, 10000] m, got 1e+12"]),
    (["calibrate", "-c", "calibrate.yaml", "--set", "groups[0].set=[release.kind=line]", "-o", "c"], BAD_INPUT,
     [": error: --set groups[0].set: release.kind: release.kind 'line' needs at least 2 points in release.points"]),
    (["calibrate", "-c", "calibrate.yaml", "--set", "parameters[0].min=0.95", "-o", "c"], BAD_INPUT,
     [": error: --set parameters[0].min: parameters[0] (rock.restitution_mean): the prior needs finite min < max"]),
    (["calibrate", "-c", "calibrate.yaml", "-o", "calibrate.yaml"], USAGE, ["-o calibrate.yaml", "settings file"]),
    (["calibrate", "-c", "calibrate.yaml", "-o", "stops.csv"], USAGE, ["-o stops.csv", "is a file"]),
    # calibrate (docs/calibration.md): settings, observed stops, posterior files.
    (["calibrate", "-c", "calibrate.yaml"], USAGE, ["-o"]),
    (["calibrate", "-c", "calibrate.yaml", "--set", "groups[0].observed=missing.csv", "-o", "c"], BAD_INPUT,
     ["missing.csv", "cannot open"]),
    (["calibrate", "-c", "calibrate.yaml", "--set", "groups[0].observed=notes.txt", "-o", "c"], BAD_INPUT,
     ["notes.txt", "header names no x and y"]),
    (["calibrate", "-c", "calibrate.yaml", "--set", "parameters[0].material=scree", "-o", "c"], BAD_INPUT,
     [": error: --set parameters[0].material: ", "material 'scree' is not in the terrain file"]),
    (["calibrate", "-c", "calibrate.yaml", "--set", "parameters[0].max=2", "-o", "c"], BAD_INPUT,
     ["rock.restitution_mean", "leaves the property's range"]),
    (["calibrate", "-c", "calibrate.yaml", "--set", "parameters[0].parameter=density", "-o", "c"], BAD_INPUT,
     ["'density' is not one of"]),
    (["calibrate", "-c", "calibrate.yaml", "--set", "groups=[]", "-o", "c"], BAD_INPUT, ["at least one observed case"]),
    (["calibrate", "-c", "calibrate.yaml", "--set", "groups[0].observed=flat.csv", "--set", "variables=distance",
      "-o", "c"], BAD_INPUT, ["flat.csv", "variables distance needs x, y"]),
    # A prior is stated, never defaulted: bounds required, a normal one's mean and sd too.
    (["calibrate", "-c", "calibrate.yaml", "--set", "parameters=[{material: rock, parameter: restitution_mean}]",
      "-o", "c"], BAD_INPUT, ["rock.restitution_mean", "needs finite min < max (both given)"]),
    (["calibrate", "-c", "calibrate.yaml", "--set", "parameters[0].prior=normal", "-o", "c"], BAD_INPUT,
     ["a normal prior needs a finite mean and sd > 0"]),
    (["calibrate", "-c", "calibrate.yaml", "--set",
      "parameters=[{material: rock, parameter: restitution_mean, prior: normal, mean: 5, sd: 0.1, min: 0.2, max: 0.9}]",
      "-o", "c"], BAD_INPUT, ["has 0 of its mass in [0.2, 0.9]"]),
    (["calibrate", "-c", "calibrate.yaml", "--set", "parameters[0].sd=0.1", "-o", "c"], BAD_INPUT,
     ["a uniform prior takes no mean or sd"]),
    (["calibrate", "-c", "calibrate.yaml", "--set", "scene=missing.yaml", "-o", "c"], BAD_INPUT, ["missing.yaml"]),
    # A budget that cannot reach generation 1 could only return the prior.
    (["calibrate", "-c", "calibrate.yaml", "--set", "max_simulations=7", "-o", "c"], BAD_INPUT,
     [": error: --set max_simulations: max_simulations 7 is below 2 x particles (8)", "no posterior"]),
    # The distance's scale is the observed stops' standard deviation: none for one stop, or
    # for values that do not spread.
    (["calibrate", "-c", "calibrate.yaml", "--set", "groups[0].observed=one.csv", "-o", "c"], BAD_INPUT,
     ["one.csv", "holds a single observed stop", "at least 2"]),
    (["calibrate", "-c", "calibrate.yaml", "--set", "groups[0].observed=flat.csv", "-o", "c"], BAD_INPUT,
     ["flat.csv", "the observed lateral offsets do not spread", "variables: runout"]),
    # Observed stops off the terrain can never be matched: named by file and row.
    (["calibrate", "-c", "calibrate.yaml", "--set", "groups[0].observed=far.csv", "-o", "c"], BAD_INPUT,
     ["far.csv: line 5: observed stop (515, 4) is outside the terrain (input coordinates: x in [0, 20], y in [0, 10])",
      "no simulated block can stop there"]),
    (["calibrate", "-c", "calibrate.yaml", "--set", "groups[0].observed=runouts.csv", "--set", "variables=runout",
      "-o", "c"], BAD_INPUT, ["runouts.csv: line 3: observed runout 40 m lies beyond the terrain", "[-3, 17] m"]),
    (["calibrate", "-c", "calibrate.yaml", "--set", "groups[0].observed=local.csv", "--set", "set=[terrain=shifted.h5]",
      "-o", "c"], BAD_INPUT,
     ["local.csv: line 2: observed stop (1012, 2005) is outside the terrain (input coordinates: x in [0, 20]",
      "it lies inside the terrain in its local frame (input coordinates minus the origin shift [-1000, -2000])",
      "give the observed stops in the terrain's input coordinates"]),
    # Published summaries (docs/calibration.md, "Summary statistics"): each names its key,
    # at the file's line or the --set key.
    (["calibrate", "-c", "calsum.yaml", "--set", "groups[0].summaries[0].statistic=mean", "-o", "c"], BAD_INPUT,
     ["--set groups[0].summaries[0].statistic", "'mean' is not one of"]),
    (["calibrate", "-c", "calsum.yaml", "--set", "groups[0].summaries[1].variable=energy", "-o", "c"], BAD_INPUT,
     ["--set groups[0].summaries[1].variable", "'energy' is not one of"]),
    (["calibrate", "-c", "calsum.yaml", "--set", "groups[0].summaries[0].sdev=0.1", "-o", "c"], BAD_INPUT,
     ["--set groups[0].summaries[0].sdev", "unknown key"]),
    (["calibrate", "-c", "calsum-neg.yaml", "-o", "c"], BAD_INPUT,
     [": error: calsum-neg.yaml:5: groups[0].summaries[1]: sd must be > 0 (the value's standard uncertainty), got -0.5"]),
    (["calibrate", "-c", "calsum.yaml", "--set", "groups[0].summaries=[{statistic: quantile, p: 0.5, value: 10}]",
      "-o", "c"], BAD_INPUT,
     [": error: --set groups[0].summaries: groups[0].summaries[0]: quantile needs sd (its standard uncertainty, m)"]),
    (["calibrate", "-c", "calsum.yaml", "--set", "groups[0].summaries[0].value=58.1", "-o", "c"], BAD_INPUT,
     [": error: --set groups[0].summaries[0].value: groups[0].summaries[0]: a share must be in [0, 1], got 58.1"]),
    (["calibrate", "-c", "calsum.yaml", "--set", "groups[0].summaries[0]={statistic: share_above, threshold: 5, "
      "count: 7, n: 5}", "-o", "c"], BAD_INPUT, ["groups[0].summaries[0]: count 7 exceeds n 5"]),
    (["calibrate", "-c", "calsum.yaml", "--set", "groups[0].summaries[0]={statistic: share_above, threshold: 5, "
      "count: 3, n: 5, sd: 0.1}", "-o", "c"], BAD_INPUT, ["groups[0].summaries[0]: give count and n, or value and sd"]),
    (["calibrate", "-c", "calsum.yaml", "--set", "groups[0].summaries[0].p=0.5", "-o", "c"], BAD_INPUT,
     ["--set groups[0].summaries[0].p: groups[0].summaries[0]: share_above takes no p"]),
    (["calibrate", "-c", "calsum.yaml", "--set", "groups[0].summaries[1].n=250", "-o", "c"], BAD_INPUT,
     [": error: --set groups[0].summaries[1].n:", "the max of n = 250 blocks needs at least as many realizations",
      "(realizations is 3)"]),
    (["calibrate", "-c", "calsum.yaml", "--set", "groups[0].observed=stops.csv", "-o", "c"], BAD_INPUT,
     ["--set groups[0].observed", "give observed stops or summaries, not both"]),
    (["calibrate", "-c", "calsum.yaml", "--set",
      "groups=[{summaries: [{statistic: max, n: 3, value: 12, sd: 0.5}]}, {observed: stops.csv}]", "-o", "c"],
     BAD_INPUT, ["groups[1] (group 1): the cases must all give observed stops or all give summaries"]),
    (["calibrate", "-c", "calibrate.yaml", "--predict", "missing.h5", "-o", "c"], BAD_INPUT, ["missing.h5"]),
    (["calibrate", "-c", "calibrate.yaml", "--predict", "t.h5", "-o", "c"], BAD_INPUT, ["t.h5"]),
    (["calibrate", "-c", "calibrate.yaml", "--predict", "run.h5", "--resume", "-o", "c"], USAGE, ["--resume"]),
]


def snapshot(root):
    files = {}
    for base, dirs, names in os.walk(root):
        for name in dirs + names:
            path = os.path.join(base, name)
            rel = os.path.relpath(path, root)
            if os.path.islink(path):
                files[rel] = "link:" + os.readlink(path)
            elif os.path.isdir(path):
                files[rel] = "dir"
            else:
                with open(path, "rb") as f:
                    files[rel] = hashlib.sha256(f.read()).hexdigest()
    return files


def run_case(bin_dir, fixtures, work, args, code, words):
    shutil.copytree(fixtures, work, symlinks=True)
    # copytree does not keep hard links: make hard.h5 one again.
    os.remove(os.path.join(work, "hard.h5"))
    os.link(os.path.join(work, "run.h5"), os.path.join(work, "hard.h5"))
    before = snapshot(work)
    tool = args[0] if args[:2] != ["dda-run", "merge"] else "dda-run merge"
    try:
        r = subprocess.run([os.path.join(bin_dir, args[0])] + args[1:], cwd=work, capture_output=True, text=True,
                           timeout=120)
    except subprocess.TimeoutExpired:
        return ["timed out (hang)"]
    problems = []
    if r.returncode != code:
        problems.append(f"exit code {r.returncode}, expected {code}")
    lines = r.stderr.splitlines()
    if len(lines) != 1:
        problems.append(f"{len(lines)} lines on stderr, expected 1")
    line = lines[0] if lines else ""
    if not line.startswith(tool + ": error: "):
        problems.append(f"error line does not start with '{tool}: error: '")
    for w in words:
        if w not in line:
            problems.append(f"error line lacks '{w}'")
    if r.stdout:
        problems.append("wrote to stdout")
    after = snapshot(work)
    for rel in sorted(set(before) | set(after)):
        if rel not in after:
            problems.append(f"{rel} was removed")
        elif rel not in before:
            problems.append(f"{rel} was created")
        elif before[rel] != after[rel]:
            problems.append(f"{rel} was changed")
    if problems:
        problems.append("stderr: " + r.stderr.strip())
    return problems


def positive_checks(bin_dir, fixtures, work):
    """Documented examples that must work."""
    problems = []
    shutil.copytree(fixtures, work, symlinks=True)
    for tool in TOOLS:
        help_text = subprocess.run([os.path.join(bin_dir, tool), "--help"], capture_output=True, text=True).stdout
        m = re.search(r"e\.g\. --set (\S+)", help_text)
        if not m:
            problems.append(f"{tool} --help shows no --set example")
            continue
        example = m.group(1)
        r = subprocess.run([os.path.join(bin_dir, tool), "--print-config", "--set", example], cwd=work,
                           capture_output=True, text=True)
        if r.returncode != 0:
            problems.append(f"{tool} --help example --set {example} fails: {r.stderr.strip()}")
    # From another directory: the run's terrain is found although the run names it relatively.
    r = subprocess.run([os.path.join(bin_dir, "stats"), "../run.h5", "-o", "../st3", "--set", "plots=false"],
                       cwd=os.path.join(work, "sub"), capture_output=True, text=True)
    if r.returncode != 0 or not os.path.isdir(os.path.join(work, "st3", "hazard")):
        problems.append(f"stats from another directory fails: {r.stderr.strip()}")
    for out in ("stats/", "./stats2/"):
        r = subprocess.run([os.path.join(bin_dir, "stats"), "run.h5", "-o", out, "--print-table", "--set", "plots=false"],
                           cwd=work, capture_output=True, text=True)
        if r.returncode != 0 or not os.path.isfile(os.path.join(work, out, "summary.csv")):
            problems.append(f"stats run.h5 -o {out} --print-table fails: {r.stderr.strip()}")
    return problems


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--bin", required=True, help="directory of the built tools")
    parser.add_argument("--keep", help="work in this directory and keep it")
    parser.add_argument("-k", dest="filter", default="", help="run only cases whose command line contains this")
    args = parser.parse_args()
    bin_dir = os.path.abspath(args.bin)
    root = args.keep or tempfile.mkdtemp(prefix="talus-bad-inputs-")
    if args.keep:
        shutil.rmtree(root, ignore_errors=True)
    fixtures = os.path.join(root, "fixtures")
    make_fixtures(bin_dir, fixtures)

    failed = 0
    ran = 0
    counts = {t: 0 for t in TOOLS}
    for k, (argv, code, words) in enumerate(CASES):
        if args.filter not in " ".join(argv):
            continue
        ran += 1
        counts[argv[0]] += 1
        problems = run_case(bin_dir, fixtures, os.path.join(root, f"case{k:03d}"), argv, code, words)
        if problems:
            failed += 1
            print(f"FAIL {' '.join(argv)}")
            for p in problems:
                print(f"     {p}")
    problems = positive_checks(bin_dir, fixtures, os.path.join(root, "positive"))
    for p in problems:
        print(f"FAIL {p}")
    print(f"{ran - failed} of {ran} bad-input cases pass ({', '.join(f'{t} {n}' for t, n in counts.items())}); "
          f"{len(problems)} failed positive checks")
    if not args.keep:
        shutil.rmtree(root, ignore_errors=True)
    return 1 if failed or problems else 0


if __name__ == "__main__":
    sys.exit(main())
