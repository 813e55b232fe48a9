#!/usr/bin/python3
"""Impacts that do not depend on the mesh: a smooth ellipsoid tumbling down a washboard,
the same shape at several mesh sizes, through terrain-gen, block-gen and dda-run
(docs/dda.md, "Impacts that do not depend on the mesh").

The ground is a 20 degree slope of 0.5 m cells whose every other row of grid points is
raised by 5 cm: a crest every metre, faces of 15 and 25 degrees (R_v 0.5, K 12 m/s,
friction angle 30 degrees, no spread, no roughness). The block is the ellipsoid
1.6 x 1.12 x 0.8 m (1 m^3, block-gen `ellipsoid` at resolution n: 20 n^2 faces), released
touching the ground 1 cm above it at x = 5 m in a random orientation per realization, for
5 s. A tumbling ellipsoid rolls, rocks, hops over the crests and lands on the faces; what
it does is a property of its shape, so impacts per realization, the distance covered and
the speed reached must not change with the face count.

Per level: the ends, impacts per realization (mean), final x (mean and P50), maximum
speed (P50). `--check` exits 1 unless every two levels' mean impacts differ by no more
than 10 % and their mean final x by no more than 5 %.

Usage:
  washboard.py --bin build/bin --out DIR [--levels 8 16 32] [--realizations 400] [--check]
               [--set KEY=VALUE ...]
Only the standard library, numpy and h5py.
"""
import argparse
import math
import os
import sys

import h5py
import numpy as np

from logged_run import run

ENDS = ["running", "rest", "left_terrain", "step_limit", "non_finite", "no_convergence", "penetration"]


def write_dem(path):
    nx, ny, cell = 241, 21, 0.5
    with open(path, "w") as f:
        f.write(f"ncols {nx}\nnrows {ny}\nxllcorner 0\nyllcorner 0\ncellsize {cell}\nNODATA_value -9999\n")
        row = " ".join("%.4f" % ((nx - 1 - i) * cell * math.tan(math.radians(20.0)) + (0.05 if i % 2 else 0.0))
                       for i in range(nx))
        for _ in range(ny):
            f.write(row + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--levels", type=int, nargs="+", default=[8, 16, 32])
    ap.add_argument("--realizations", type=int, default=400)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--check", action="store_true")
    ap.add_argument("--set", action="append", default=[], help="KEY=VALUE passed to every dda-run")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    log = os.path.join(args.out, "log.txt")
    open(log, "w").close()

    dem, terrain = os.path.join(args.out, "washboard.asc"), os.path.join(args.out, "washboard.h5")
    write_dem(dem)
    run([f"{args.bin}/terrain-gen", dem, "--set", "roughness.roughness_index=0",
         "--set", "materials[0].restitution_mean=0.5", "--set", "materials[0].restitution_sd=0",
         "--set", "materials[0].restitution_scale=12", "--set", "materials[0].friction_angle_mean_deg=30",
         "--set", "materials[0].friction_coefficient_sd=0", "--set", "materials[0].lateral_tilt_sd_deg=0",
         "-o", terrain, "-q"], log)
    specs = ", ".join(f"{{name: e{n}, solid: ellipsoid, dimensions: [1.6, 1.12, 0.8], volume: 1, resolution: {n}}}"
                      for n in args.levels)
    blocks = os.path.join(args.out, "blocks.h5")
    run([f"{args.bin}/block-gen", "--set", f"blocks=[{specs}]", "-o", blocks, "-q"], log)

    extra = []
    for kv in args.set:
        extra += ["--set", kv]
    rows = {}
    for n in args.levels:
        out = os.path.join(args.out, f"run-e{n}.h5")
        run([f"{args.bin}/dda-run", "--set", f"terrain={terrain}", "--set", f"block_file={blocks}",
             "--set", f"blocks=[e{n}]", "--set", "release.points=[[5, 5]]", "--set", "release.height=0.01",
             "--set", "release.height_reference=lowest_point", "--set", f"realizations={args.realizations}",
             "--set", "engine.max_time=5", "--set", "stochastic.roughness=false",
             "--set", "stochastic.restitution=false", "--set", "stochastic.friction=false",
             "--set", "stochastic.lateral_tilt=false", "--threads", str(args.threads), "-q"] + extra + ["-o", out], log)
        with h5py.File(out, "r") as f:
            r = f["records"]
            ends = np.bincount(r["end_reason"][:], minlength=len(ENDS))
            x = r["final_position"][:, 0]
            rows[n] = dict(faces=20 * n * n, ends=ends, impacts=float(np.mean(r["impacts"][:])),
                           x_mean=float(np.mean(x)), x_p50=float(np.median(x)),
                           speed_p50=float(np.median(r["max_speed"][:])))

    lines = ["| faces | ends | impacts per realization | final x mean / P50 (m) | max speed P50 (m/s) |",
             "|---|---|---|---|---|"]
    for n in args.levels:
        q = rows[n]
        ends = ", ".join(f"{ENDS[i]} {c}" for i, c in enumerate(q["ends"]) if c)
        lines.append(f"| {q['faces']} | {ends} | {q['impacts']:.2f} | {q['x_mean']:.2f} / {q['x_p50']:.2f} | "
                     f"{q['speed_p50']:.2f} |")
    text = "\n".join(lines)
    print(text)
    with open(os.path.join(args.out, "washboard.md"), "w") as f:
        f.write(text + "\n")

    if args.check:
        failed = []
        for i, a in enumerate(args.levels):
            for b in args.levels[i + 1:]:
                qa, qb = rows[a], rows[b]
                if abs(qa["impacts"] - qb["impacts"]) > 0.10 * max(qa["impacts"], qb["impacts"]):
                    failed.append(f"impacts per realization {qa['impacts']:.2f} ({qa['faces']} faces) against "
                                  f"{qb['impacts']:.2f} ({qb['faces']} faces): more than 10 % apart")
                if abs(qa["x_mean"] - qb["x_mean"]) > 0.05 * max(abs(qa["x_mean"]), abs(qb["x_mean"])):
                    failed.append(f"mean final x {qa['x_mean']:.2f} m ({qa['faces']} faces) against "
                                  f"{qb['x_mean']:.2f} m ({qb['faces']} faces): more than 5 % apart")
        for q in rows.values():
            if q["ends"][4:].sum():
                failed.append(f"{int(q['ends'][4:].sum())} numerical failures at {q['faces']} faces")
        for msg in failed:
            print("washboard.py: " + msg, file=sys.stderr)
        sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
