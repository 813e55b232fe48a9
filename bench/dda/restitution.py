#!/usr/bin/python3
"""The restitution law as what the block does: cubes thrown face down onto a flat plane
through terrain-gen, block-gen and dda-run, the rebound measured from the flight after the
impact and compared with the law (docs/dda.md, "Impact-rebound").

The rebound is read from positions only: three trajectory samples of the first upward
parabola after the impact give its apex height above the touch level and its horizontal
speed, so V_out,z = sqrt(2 g (z_apex - z_touch)) and |V_out| = sqrt(V_out,z^2 + V_h^2).
The law's rebound for an impact at V_in (the parabola's velocity at the touch):

  normal impacts:  |V_out| = R_v * SF * |V_in|, SF = 1 / (1 + (|V_in| / K)^2)
  oblique impacts: the same rule applied to the raw DDA rebound, measured the same way in
                   a run with `restitution: off`: its kinetic energy (spin included) scaled
                   to min(1, (R_v SF |V_in| / |V_raw|)^2, (R_v SF)^2 E_in / E_raw), but
                   never below E_raw - E_n, E_n = m (V_in . n)^2 / 2 (the law removes at
                   most the normal approach's energy).

Usage:
  restitution.py --bin build/bin --out DIR [--quick] [--tolerance 0.01]

Prints one line per case and exits 1 if a rebound is off the law by more than the
tolerance (relative, on the speed). Only the standard library, numpy and h5py.
"""

import argparse
import math
import os
import sys

import h5py
import numpy as np

from logged_run import run

G = 9.81


def terrain(args, rv, path, log):
    run([f"{args.bin}/terrain-gen", "--set", "synthetic.kind=plane", "--set", "synthetic.slope_angle_deg=0",
         "--set", "synthetic.length=400", "--set", "synthetic.width=200", "--set", "synthetic.cell_size=20",
         "--set", f"materials[0].restitution_mean={rv}", "--set", "materials[0].restitution_sd=0",
         "--set", "materials[0].restitution_scale=12", "--set", "materials[0].friction_angle_mean_deg=30",
         "--set", "materials[0].friction_coefficient_sd=0", "--set", "materials[0].lateral_tilt_sd_deg=0",
         "-o", path], log)


def rebound(path, edge, mass, inertia):
    """V_in at the touch, V_out (speed), E_out (J) and the rebound's horizontal and vertical
    speed, from the trajectory: positions of the parabolas before and after the first impact."""
    t = h5py.File(path)["trajectories"]
    time, pos, motion = t["time"][:], t["position"][:], t["motion"][:]
    spin, velocity = t["angular_velocity"][:], t["velocity"][:]
    # The impact may fall between two samples (a small block's steps are short): the
    # rebound is the first parabola after the centroid has turned upwards.
    rising = np.nonzero(velocity[:, 2] > 0.0)[0]
    if len(rising) == 0:
        return None
    first = rising[0]
    after = [k for k in range(first, len(time) - 3) if motion[k] == 0 and motion[k + 1] == 0 and motion[k + 2] == 0]
    if not after:
        return None
    k = after[0]
    # Only flight samples that are evenly spaced lie on one parabola sampled at equal steps;
    # a parabola through three points (any spacing): z = a t^2 + b t + c.
    ts, zs = time[k:k + 3] - time[k], pos[k:k + 3, 2]
    a, b, c = np.polyfit(ts, zs, 2)
    apex = c - b * b / (4.0 * a)
    touch = edge / 2.0
    vz = math.sqrt(max(0.0, 2.0 * G * (apex - touch)))
    vh = np.linalg.norm((pos[k + 2, :2] - pos[k, :2]) / (time[k + 2] - time[k]))
    w = spin[k + 1]
    energy = 0.5 * mass * (vz * vz + vh * vh) + 0.5 * inertia * w.dot(w)
    return math.hypot(vz, vh), energy, vz, vh


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--quick", action="store_true", help="a subset: 1 m^3, R_v 0.5 and 0.95, 3 speeds")
    ap.add_argument("--tolerance", type=float, default=0.01)
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    log = os.path.join(args.out, "log.txt")
    open(log, "w").close()

    volumes = [1.0] if args.quick else [1e-3, 1.0, 1000.0]
    restitutions = [0.5, 0.95] if args.quick else [0.2, 0.5, 0.95]
    speeds = [3.0, 12.0, 50.0] if args.quick else [3.0, 7.0, 12.0, 25.0, 50.0]
    incidences = [0.0, 20.0, 45.0]  # angle of V_in from the normal (deg)

    for rv in restitutions:
        terrain(args, rv, os.path.join(args.out, f"plane-{rv}.h5"), log)
    for v in volumes:
        run([f"{args.bin}/block-gen", "--set", f"blocks=[{{name: cube, solid: cube, volume: {v}}}]",
             "-o", os.path.join(args.out, f"cube-{v}.h5")], log)

    worst, failures, cases = 0.0, 0, 0
    print(f"{'V/m3':>7} {'R_v':>5} {'V_in':>6} {'inc':>4} {'law':>9} {'measured':>9} {'error':>10}")
    for v in volumes:
        edge = v ** (1.0 / 3.0)
        mass = 2800.0 * v
        inertia = mass * edge * edge / 6.0
        for rv in restitutions:
            for speed in speeds:
                for inc in incidences:
                    gap = 0.02 * edge
                    a = math.radians(inc)
                    # Thrown so that the velocity at the touch is `speed` at `inc` from the normal.
                    vz_touch = speed * math.cos(a)
                    vz0 = math.sqrt(max(0.0, vz_touch ** 2 - 2.0 * G * gap))
                    vx = speed * math.sin(a)
                    v_in = math.hypot(vx, vz_touch)
                    flight = 2.0 * speed / G + 1.0
                    outs = {}
                    for law in (["scaled"] if inc == 0.0 else ["scaled", "off"]):
                        out = os.path.join(args.out, f"run-{v}-{rv}-{speed}-{inc}-{law}.h5")
                        run([f"{args.bin}/dda-run", "--set", f"terrain={args.out}/plane-{rv}.h5",
                             "--set", f"block_file={args.out}/cube-{v}.h5", "--set", "release.points=[[60, 100]]",
                             "--set", f"release.height={edge / 2 + gap}", "--set", "release.orientation=fixed",
                             "--set", f"release.velocity=[{vx}, 0, {-vz0}]", "--set", "realizations=1",
                             "--set", f"engine.restitution={law}", "--set", f"engine.max_time={flight}",
                             "--set", "engine.trajectory_interval=0.001", "-o", out, "-q"], log)
                        outs[law] = rebound(out, edge, mass, inertia)
                    sf = 1.0 / (1.0 + (v_in / 12.0) ** 2)
                    cap = rv * sf * v_in
                    measured = outs["scaled"]
                    if inc == 0.0:
                        law_speed = cap
                    else:
                        raw = outs["off"]
                        e_in = 0.5 * mass * v_in * v_in
                        e_raw = raw[1]
                        f2 = min(1.0, (cap / raw[0]) ** 2, (rv * sf) ** 2 * e_in / e_raw)
                        e_n = 0.5 * mass * vz_touch ** 2
                        f2 = max(f2, 1.0 - e_n / e_raw)
                        law_speed = math.sqrt(f2) * raw[0]
                    got = measured[0] if measured else 0.0
                    err = (got - law_speed) / law_speed
                    cases += 1
                    worst = max(worst, abs(err))
                    flag = "" if abs(err) <= args.tolerance else "  <-- off the law"
                    failures += abs(err) > args.tolerance
                    print(f"{v:7g} {rv:5.2f} {v_in:6.2f} {inc:4.0f} {law_speed:9.4f} {got:9.4f} {err:+10.2e}{flag}")
    print(f"restitution.py: {cases} impacts, largest error {worst:.4f} (tolerance {args.tolerance})")
    print(f"{cases - failures} passed, {failures} failed")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
