#!/usr/bin/python3
"""Impact tests of ground materials through the four tools: what one impact does to a block.

For each material (a built-in class, or explicit parameters) a horizontal plane of that
material is built with `terrain-gen`, blocks of 1 m^3 are built with `block-gen`, and
`dda-run` throws them at the plane at a given speed and incidence (angle of the velocity
below the horizontal) with trajectories sampled at every step. The first contact of each
realization is read from its trajectory:

  V_in   the velocity of the last sample of the parabola before the contact,
  V_out  the velocity of the first sample of the upward parabola that ends the impact
         (at least 5 ms of flight; contacts separated by a downward parabola, a corner
         that tips the block before the rest of it lands, belong to one impact). A block
         that never leaves the ground upwards counts as e_n = 0.

and reported as the normal restitution e_n = V_out,z / -V_in,z, the tangential ratio
e_t = |V_out,xy| / |V_in,xy| (centroid velocities) and the ratio of the total kinetic
energy (spin included, from the sampled energy) E_out / E_in.

Usage:
  impacts.py --bin build/bin --out DIR [--classes a,b,...] [--speed 10] [--incidence 90]
             [--realizations 64] [--block cube|platonic] [--orientation random|face]
             [--stochastic] [--json FILE] [--check TOL]
  impacts.py --bin build/bin --out DIR --fit NAME:RN:PHI [--fit ...] [--realizations 256]
             finds, by bisection, the mean restitution R_v (no speed scaling, K = 1000 m/s,
             no scatter) whose median e_n is RN at the given impact, friction angle PHI (deg):
             how the built-in classes were derived (docs/materials.md)

Only the standard library, numpy and h5py (Debian python3-numpy, python3-h5py) are used.
"""

import argparse
import json
import math
import os
import subprocess
import sys

import numpy as np

G = 9.81
# A sample is on the parabola when its acceleration differs from gravity by less than
# this (m/s^2); contact accelerations of a 1 m^3 block are orders of magnitude larger.
BALLISTIC_TOL = 0.05
MIN_FLIGHT = 5  # samples (ms at 1 ms) the rebound must fly to count as a rebound


def run(cmd, log):
    with open(log, "a") as f:
        f.write(" ".join(cmd) + "\n")
        r = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT)
    if r.returncode != 0:
        sys.exit("impacts.py: command failed (see %s): %s" % (log, " ".join(cmd)))


def list_classes(bindir):
    """{class name: published normal restitution R_n} from terrain-gen --list-material-classes."""
    out = subprocess.run([os.path.join(bindir, "terrain-gen"), "--list-material-classes"],
                         check=True, capture_output=True, text=True).stdout
    classes = {}
    for line in out.splitlines():
        if line and not line.startswith((" ", "#", "class")):
            fields = line.split()
            classes[fields[0]] = float(fields[-1])
    return classes


def terrain_yaml(material):
    lines = ["name: impact-plane", "source: synthetic", "triangulation: alternating",
             "synthetic:", "  kind: plane", "  cell_size: 2", "  width: 40", "  length: 40",
             "  slope_angle_deg: 0", "materials:", "  - name: ground"]
    for k, v in material.items():
        lines.append("    %s: %s" % (k, v))
    return "\n".join(lines) + "\n"


def block_yaml(kind):
    solids = ["cube"] if kind == "cube" else ["tetrahedron", "cube", "octahedron", "dodecahedron"]
    lines = ["density: 2800", "blocks:"]
    for s in solids:
        lines += ["  - name: %s" % s, "    solid: %s" % s, "    volume: 1.0"]
    return "\n".join(lines) + "\n", solids


def scene_yaml(terrain, blocks, names, speed, incidence_deg, realizations, orientation, stochastic):
    a = math.radians(incidence_deg)
    vx, vz = speed * math.cos(a), -speed * math.sin(a)
    # The block's lowest point starts 0.2 m above the plane: a short parabola brings it
    # down, so the impact speed and angle are the given ones to within that fall (the
    # measured speed is reported).
    orient = "fixed" if orientation == "face" else "random"
    return "\n".join([
        'schema_version: "1.0"',
        "terrain: %s" % terrain,
        "block_file: %s" % blocks,
        "blocks: [%s]" % ", ".join(names),
        "block_selection: cycle",
        "release:",
        "  kind: point",
        "  points: [[10.0, 20.0]]",
        "  height: 0.2",
        "  height_reference: lowest_point",
        "  orientation: %s" % orient,
        "  orientation_deg: [0, 0, 0]",
        "  velocity: [%.9g, 0, %.9g]" % (vx, vz),
        "realizations: %d" % realizations,
        "seed: 7",
        "stochastic:",
        "  roughness: false",
        "  restitution: %s" % ("true" if stochastic else "false"),
        "  friction: %s" % ("true" if stochastic else "false"),
        "  lateral_tilt: false",
        "engine:",
        "  trajectory_interval: 0.001",
        "  max_time: 1.5",
        "outputs:",
        "  hazard_cell_size: 0",
    ]) + "\n"


def first_impact(t, v, energy, pos):
    """(v_in, v_out or None, E_in, E_out) of the first contact of one trajectory."""
    n = len(t)
    if n < 3:
        return None
    acc = np.diff(v, axis=0) / np.diff(t)[:, None]
    ballistic = np.linalg.norm(acc - np.array([0.0, 0.0, -G]), axis=1) < BALLISTIC_TOL
    # ballistic[k]: the step from sample k to k+1 followed the parabola.
    k = 0
    while k < len(ballistic) and ballistic[k]:
        k += 1
    if k == len(ballistic):
        return None
    k_in = k  # last sample before the contact acted
    kin = lambda j: energy[j] - 2800.0 * G * pos[j, 2]  # kinetic per m^3 block mass (2800 kg)
    # The impact ends when the block leaves the ground upwards: a parabola of at least
    # MIN_FLIGHT samples starting with an upward velocity. A corner that touches, tips the
    # block and lets it fall on (a downward parabola between contacts) is part of it.
    j = k_in + 1
    while j + MIN_FLIGHT <= len(ballistic):
        if v[j, 2] > 0.0 and ballistic[j:j + MIN_FLIGHT].all():
            return v[k_in], v[j], kin(k_in), kin(j)
        j += 1
    return v[k_in], None, kin(k_in), None


def measure(h5path):
    import h5py
    with h5py.File(h5path, "r") as f:
        tr = f["trajectories"]
        real = tr["realization"][:]
        t, pos, vel, en = tr["time"][:], tr["position"][:], tr["velocity"][:], tr["energy"][:]
    rows = []
    for r in np.unique(real):
        sel = real == r
        res = first_impact(t[sel], vel[sel], en[sel], pos[sel])
        if res is None:
            continue
        vin, vout, ein, eout = res
        vin_n, vin_t = -vin[2], math.hypot(vin[0], vin[1])
        if vout is None:
            rows.append((0.0, float("nan"), 0.0, np.linalg.norm(vin)))
            continue
        e_n = vout[2] / vin_n
        e_t = math.hypot(vout[0], vout[1]) / vin_t if vin_t > 1e-6 else float("nan")
        rows.append((e_n, e_t, eout / ein, np.linalg.norm(vin)))
    return np.array(rows)


def summarize(rows):
    def q(col, p):
        x = rows[:, col]
        x = x[np.isfinite(x)]
        return float(np.quantile(x, p)) if len(x) else float("nan")
    return {
        "n": int(len(rows)),
        "rebounds": int(np.sum(rows[:, 0] > 0)),
        "speed_in": float(np.median(rows[:, 3])),
        "e_n": [q(0, 0.1), q(0, 0.5), q(0, 0.9)],
        "e_t": [q(1, 0.1), q(1, 0.5), q(1, 0.9)],
        "energy_ratio": [q(2, 0.1), q(2, 0.5), q(2, 0.9)],
    }


def impact_test(args, name, material, log):
    """Runs the impact test of one material; returns its summary."""
    byaml, solids = block_yaml(args.block)
    bpath = os.path.join(args.out, "blocks-%s.yaml" % args.block)
    bh5 = os.path.join(args.out, "blocks-%s.h5" % args.block)
    if not os.path.exists(bh5):
        with open(bpath, "w") as f:
            f.write(byaml)
        run([os.path.join(args.bin, "block-gen"), "-c", bpath, "-o", bh5], log)
    tpath = os.path.join(args.out, "terrain-%s.yaml" % name)
    th5 = os.path.join(args.out, "terrain-%s.h5" % name)
    with open(tpath, "w") as f:
        f.write(terrain_yaml(material))
    run([os.path.join(args.bin, "terrain-gen"), "-c", tpath, "-o", th5], log)
    tag = "%s-v%g-a%g-%s-%s" % (name, args.speed, args.incidence, args.block, args.orientation)
    spath = os.path.join(args.out, "scene-%s.yaml" % tag)
    rh5 = os.path.join(args.out, "run-%s.h5" % tag)
    with open(spath, "w") as f:
        f.write(scene_yaml(th5, bh5, solids, args.speed, args.incidence, args.realizations,
                           args.orientation, args.stochastic))
    run([os.path.join(args.bin, "dda-run"), "-c", spath, "-o", rh5, "--threads", "2"], log)
    return summarize(measure(rh5))


def fit(args):
    os.makedirs(args.out, exist_ok=True)
    log = os.path.join(args.out, "commands.log")
    print("| material | target e_n | friction angle (deg) | R_v | median e_n |")
    print("|---|---|---|---|---|")
    for spec in args.fit:
        name, rn, phi = spec.split(":")
        rn, phi = float(rn), float(phi)
        lo, hi = 0.0, 1.0
        got = None
        for _ in range(11):  # 1/2048 of the range
            mid = 0.5 * (lo + hi)
            material = {"restitution_mean": "%.6f" % mid, "restitution_sd": 0, "restitution_scale": 1000,
                        "friction_angle_mean_deg": phi, "friction_coefficient_sd": 0, "lateral_tilt_sd_deg": 0}
            got = impact_test(args, name, material, log)["e_n"][1]
            if got < rn:
                lo = mid
            else:
                hi = mid
        r = 0.5 * (lo + hi)
        material["restitution_mean"] = "%.6f" % r
        got = impact_test(args, name, material, log)["e_n"][1]
        print("| %s | %.2f | %g | %.3f | %.3f |" % (name, rn, phi, r, got))
        sys.stdout.flush()


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bin", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--classes", default="", help="comma-separated class names; empty: all")
    ap.add_argument("--material", action="append", default=[],
                    help="NAME:key=value,key=value explicit material instead of a class")
    ap.add_argument("--speed", type=float, default=10.0, help="impact speed (m/s)")
    ap.add_argument("--incidence", type=float, default=90.0, help="angle below the horizontal (deg)")
    ap.add_argument("--realizations", type=int, default=64)
    ap.add_argument("--block", choices=["cube", "platonic"], default="platonic")
    ap.add_argument("--orientation", choices=["random", "face"], default="random")
    ap.add_argument("--stochastic", action="store_true", help="draw R_v and friction per impact")
    ap.add_argument("--json", default="")
    ap.add_argument("--fit", action="append", default=[], help="NAME:RN:PHI, see above")
    ap.add_argument("--check", type=float, default=0.0,
                    help="fail (exit 1) when a class's median e_n is further than this from its R_n")
    args = ap.parse_args()
    if args.fit:
        fit(args)
        return

    os.makedirs(args.out, exist_ok=True)
    log = os.path.join(args.out, "commands.log")
    materials = []
    known = {}
    if args.material:
        for spec in args.material:
            name, _, kv = spec.partition(":")
            materials.append((name, dict(p.split("=") for p in kv.split(",") if p)))
    else:
        known = list_classes(args.bin)
        names = args.classes.split(",") if args.classes else list(known)
        materials = [(n, {"class": n}) for n in names]

    results = {}
    for name, material in materials:
        results[name] = impact_test(args, name, material, log)

    print("| material | impacts | rebounds | V_in (m/s) | e_n p10 / p50 / p90 | e_t p10 / p50 / p90 | E_out/E_in p10 / p50 / p90 |")
    print("|---|---|---|---|---|---|---|")
    for name, s in results.items():
        f3 = lambda xs: " / ".join("%.2f" % x for x in xs)
        print("| %s | %d | %d | %.1f | %s | %s | %s |" % (name, s["n"], s["rebounds"], s["speed_in"],
                                                        f3(s["e_n"]), f3(s["e_t"]), f3(s["energy_ratio"])))
    failures = []
    if args.check > 0.0:
        for name, s in results.items():
            target = known.get(name)
            if target is not None and not abs(s["e_n"][1] - target) <= args.check:
                failures.append("%s: median e_n %.3f, R_n %.2f" % (name, s["e_n"][1], target))
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"speed": args.speed, "incidence": args.incidence, "block": args.block,
                       "orientation": args.orientation, "results": results}, f, indent=1)
    if failures:
        sys.exit("impacts.py: median normal restitution off its class's R_n by more than %g: %s"
                 % (args.check, "; ".join(failures)))


if __name__ == "__main__":
    main()
