#!/usr/bin/python3
"""The Authume quarry field experiment through the tools: where Talus's blocks stop against
where the 89 boulders released there stopped.

The data (Garcia et al. 2022, Engineering Geology 310, 106855; published with the
Data in Brief paper) are not part of Talus: clone them and give their folder,

  git clone https://github.com/richefeu/AuthumeQuarryRockfalls_Data-in-Brief authume

then

  bench/field/authume.py --data authume --bin build/bin --out out/authume

builds the lidar TIN with its three substrate zones (terrain-gen; the files are y-up), the
four photogrammetric blocks (block-gen), and for each profile releases them at the four
drop points of the data, in the data's 64 orientations (`release.orientation: list`, every
block in every orientation, block i mod 4, 1 024 realizations by default: Rockable's
design), from the drop points' elevation. Then, per material set and profile, it compares
the horizontal distance of each stop from the mean drop point with the measured ones:

  - the measured and simulated P10 / P50 / P90, and the simulated 5-95 % band;
  - KS distance over every realization, a block that did not come to rest on the survey
    counted as stopping beyond every measured one (censored: every measured block
    stopped), and KS among the blocks at rest;
  - the share at rest on the survey, and the lateral standard deviation of the stops
    across the direction from the mean drop point to the mean measured stop.

Material sets: `defaults` (terrain-gen's default material on all three zones) and
`classes` (classes of docs/materials.md chosen from the substrate descriptions of the
data: gray, hard ground and rock walls, `bedrock`; red, rocky slope, `compact_scree`;
blue, vegetated slope, `soil`). Writes table.md and stops.png in --out; the run files
stay there for `stats`, with each profile's measured stops as calibrate's observed CSV
(observed-P1.csv) and a calibrate settings file fitting the zones' restitution to them
(calibrate-P1.yaml; a starting point). When the data folder holds the Rockable simulations published
with it (SIM_Trajectories), their final positions are measured the same way, as a row
"Rockable" per profile.

Only the standard library, numpy, h5py and matplotlib (Debian python3-numpy, -h5py,
-matplotlib) are used.
"""

import argparse
import collections
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "dda"))
from logged_run import run  # noqa: E402

ZONES = {"DTM_Gray_zone": "bedrock", "DTM_Red_zone": "compact_scree", "DTM_Blue_zone": "soil"}
BLOCKS = ["SP1A", "SP2A", "SP2B", "SP3A"]
PROFILES = ["P1", "P2"]


def fail(message):
    sys.exit(f"authume.py: {message}")


def read_rows(path, columns):
    """Numeric rows of a whitespace-separated text file (a header row is skipped)."""
    rows = []
    try:
        lines = open(path).read().splitlines()
    except OSError as e:
        fail(f"{path}: {e.strerror}")
    for n, line in enumerate(lines, 1):
        fields = line.split()
        if not fields:
            continue
        try:
            values = [float(v) for v in fields]
        except ValueError:
            if not rows:
                continue
            fail(f"{path}: line {n}: not numbers: {line!r}")
        if len(values) < columns:
            fail(f"{path}: line {n}: expected {columns} columns, got {len(values)}")
        rows.append(values[:columns])
    if not rows:
        fail(f"{path}: no rows")
    return np.array(rows)


def plan(xyz):
    """The data's y-up (x, y, z) as Talus's plan (x, -z) (terrain-gen tin.up_axis y)."""
    return np.stack([xyz[:, 0], -xyz[:, 2]], axis=1)


# A profile's drop points (the data's y-up x, y, z), its measured stops in plan, the mean
# drop point in plan and the azimuth (deg) from it to the mean measured stop.
Profile = collections.namedtuple("Profile", "name drops stops origin azimuth")


def read_profile(args, name):
    drops = read_rows(os.path.join(args.data, "Drop_conditions", f"positions_{name}.xyz"), 3)
    stops = plan(read_rows(os.path.join(args.data, "EXP_endpoints", f"Endpoints_{name}.txt"), 3))
    origin = plan(drops).mean(axis=0)
    towards = stops.mean(axis=0) - origin
    return Profile(name, drops, stops, origin, math.degrees(math.atan2(towards[1], towards[0])))


def ks_censored(measured, simulated, at_rest):
    """KS distance between the measured distances and the simulated ones, realizations not
    at rest counted beyond every measured distance (their CDF never reaches them)."""
    m = np.sort(measured)
    s = np.sort(simulated[at_rest])
    n = len(simulated)
    grid = np.concatenate([m, s])
    f_m = np.searchsorted(m, grid, side="right") / len(m)
    f_s = np.searchsorted(s, grid, side="right") / n
    f_m_left = np.searchsorted(m, grid, side="left") / len(m)
    f_s_left = np.searchsorted(s, grid, side="left") / n
    return float(max(np.max(np.abs(f_m - f_s)), np.max(np.abs(f_m_left - f_s_left))))


def ks(a, b):
    if len(a) == 0 or len(b) == 0:
        return float("nan")
    return ks_censored(a, b, np.ones(len(b), dtype=bool))


def build(args, work, log):
    stl = os.path.join(args.data, "Geometries", "STL")
    for name in list(ZONES) + BLOCKS:
        if not os.path.exists(os.path.join(stl, name + ".stl")):
            fail(f"{os.path.join(stl, name + '.stl')}: missing (is --data the dataset's folder?)")
    terrain = os.path.join(work, "terrain.h5")
    blocks = os.path.join(work, "blocks.h5")
    with open(os.path.join(work, "terrain.yaml"), "w") as f:
        f.write("# The Authume lidar TIN (0.5 m), y up; one material per zone file.\n"
                "name: authume\nseed: 1\nsource: tin\ntin: {mode: keep, up_axis: y}\n"
                f"roughness: {{sigma: {args.sigma}}}  # m\n")
    run([os.path.join(args.bin, "terrain-gen"), "-c", os.path.join(work, "terrain.yaml")] +
        [os.path.join(stl, z + ".stl") for z in ZONES] + ["-o", terrain], log)
    with open(os.path.join(work, "blocks.yaml"), "w") as f:
        f.write(f"density: {args.density}  # kg/m^3\nblocks:\n")
        for b in BLOCKS:
            f.write(f"  - {{name: {b}, mesh: {os.path.join(stl, b + '.stl')}, "
                    "input: {up_axis: y, repair: {orient: true, stitch: true, fill_holes: true}}}\n")
    run([os.path.join(args.bin, "block-gen"), "-c", os.path.join(work, "blocks.yaml"), "-o", blocks], log)
    return terrain, blocks


def scene(args, work, terrain, blocks, profile, materials, fitted=None, name=None):
    """The dda-run scene of `profile`: the classes' zones (with --material and the `fitted`
    {zone: {property: value}} beside them) or the terrain file's defaults."""
    path = os.path.join(work, f"{name or materials}-{profile.name}.yaml")
    with open(path, "w") as f:
        f.write(f"# Authume {profile.name}, {materials}: the data's drop points and orientations.\n"
                f"schema_version: \"1.0\"\nterrain: {terrain}\nblock_file: {blocks}\n"
                "block_selection: cycle\n")
        if args.law != "scaled":
            f.write(f"engine:\n  restitution: {args.law}\n")
        if materials == "classes":
            f.write("materials:\n")
            for zone, cls in ZONES.items():
                extra = "".join(f", {kv.split('=', 1)[0]}: {kv.split('=', 1)[1]}"
                                for c, kv in (o.split(":", 1) for o in args.material) if c == cls)
                extra += "".join(f", {key}: {value:.6g}" for key, value in (fitted or {}).get(zone, {}).items())
                f.write(f"  - {{name: {zone}, class: {cls}{extra}}}\n")
        points = ", ".join(f"[{p[0]:.4f}, {p[1]:.4f}]" for p in plan(profile.drops))
        f.write("release:\n  kind: point\n"
                f"  points: [{points}]   # m, plan (x, -z) of the data's y-up drop points\n"
                "  height_reference: elevation\n"
                f"  height: {profile.drops[:, 1].mean():.4f}   # m, the drop points' elevation (their y)\n"
                "  clearance: lift\n  orientation: list\n"
                f"  orientation_file: {os.path.join(args.data, 'Drop_conditions', 'orientations.txt')}\n"
                "  orientation_up_axis: y\n"
                f"  main_direction_deg: {profile.azimuth:.3f}   # from the mean drop point to the mean measured stop\n"
                f"realizations: {args.realizations}\nseed: {args.seed}\n")
    return path


def calibration_files(args, work, profile):
    """The measured stops as calibrate's observed CSV (plan x, y in the terrain's input
    coordinates) and a calibrate settings file fitting the classes' three zones to them,
    compared by distance from the mean drop point (docs/calibration.md)."""
    name = profile.name
    observed = os.path.join(work, f"observed-{name}.csv")
    with open(observed, "w") as f:
        f.write("x,y\n")
        for x, y in profile.stops:
            f.write(f"{x:.3f},{y:.3f}\n")
    path = os.path.join(work, f"calibrate-{name}.yaml")
    with open(path, "w") as f:
        f.write(f"# Fits the zones' materials to the measured stops of {name}; a starting point:\n"
                f"#   calibrate -c {path} -o {os.path.join(work, 'fit-' + name)}\n"
                f"scene: {os.path.join(work, 'classes-' + name + '.yaml')}\n"
                "groups:\n"
                f"  - name: {name}\n    observed: {observed}\n"
                f"    origin: [{profile.origin[0]:.4f}, {profile.origin[1]:.4f}]   # m, the mean drop point\n"
                "parameters:\n")
        if args.law == "point":
            f.write("  - {material: DTM_Gray_zone, parameter: ploughing, min: 0, max: 1}\n"
                    "  - {material: DTM_Blue_zone, parameter: ploughing, min: 0, max: 1}\n"
                    "  - {material: DTM_Blue_zone, parameter: restitution_mean, min: 0.1, max: 0.9}\n")
        else:
            f.write("  - {material: DTM_Gray_zone, parameter: restitution_mean, min: 0.1, max: 0.95}\n"
                    "  - {material: DTM_Gray_zone, parameter: restitution_scale, min: 3, max: 40}   # m/s\n"
                    "  - {material: DTM_Blue_zone, parameter: restitution_mean, min: 0.1, max: 0.95}\n")
        f.write(f"variables: distance\nrealizations: {args.calibration[1]}\nparticles: {args.calibration[0]}\n"
                f"generations: {args.calibration[2]}\n")


def fitted_medians(summary_csv):
    """{zone: {property: posterior median}} from calibrate's summary.csv."""
    fitted = {}
    with open(summary_csv) as f:
        header = f.readline().strip().split(",")
        for line in f:
            row = dict(zip(header, line.strip().split(",")))
            zone, prop = row["parameter"].rsplit(".", 1)
            fitted.setdefault(zone, {})[prop] = float(row["P50"])
    return fitted


def read_run(run_file):
    import h5py

    with h5py.File(run_file, "r") as f:
        r = f["records"]
        return np.array(r["final_position"])[:, :2], np.array(r["end_reason"]) == 1  # 1: rest


def measure(profile, final, at_rest):
    """Simulated final plan positions (and whether each came to rest) against the measured
    stops of `profile`."""
    azimuth = math.radians(profile.azimuth)
    v = np.array([-math.sin(azimuth), math.cos(azimuth)])  # across the direction to the stops
    measured = profile.stops - profile.origin
    simulated = final - profile.origin
    d_m = np.hypot(measured[:, 0], measured[:, 1])
    d_s = np.hypot(simulated[:, 0], simulated[:, 1])
    rested = d_s[at_rest]
    q = lambda x, p: float(np.quantile(x, p)) if len(x) else float("nan")
    return {
        "n": len(d_s), "rest": int(at_rest.sum()),
        "measured": (q(d_m, 0.1), q(d_m, 0.5), q(d_m, 0.9)),
        "simulated": (q(rested, 0.05), q(rested, 0.1), q(rested, 0.5), q(rested, 0.9), q(rested, 0.95)),
        "ks_censored": ks_censored(d_m, d_s, at_rest), "ks_rest": ks(d_m, rested),
        "lateral_sd": (float(np.std(measured @ v, ddof=1)), float(np.std(simulated[at_rest] @ v, ddof=1))
                       if at_rest.sum() > 1 else float("nan")),
        "plan_measured": measured, "plan_simulated": simulated, "at_rest": at_rest, "d_m": d_m, "d_s": d_s,
    }


def rockable(args, profile):
    """The Rockable simulations published with the data (SIM_Trajectories: 4 shapes x 4
    drop points x 64 orientations, 19 s each), measured as ours: None if absent. A block
    is at rest when its last sample moves slower than 0.1 m/s."""
    root = os.path.join(args.data, "SIM_Trajectories", profile)
    if not os.path.isdir(root):
        return None
    ends, speeds = [], []
    for folder, _, files in sorted(os.walk(root)):
        for name in sorted(files):
            if not name.endswith(".txt"):
                continue
            last = None
            with open(os.path.join(folder, name)) as f:
                for line in f:
                    if line.strip():
                        last = line
            row = [float(v) for v in last.split()]
            ends.append(row[1:4])
            speeds.append(math.sqrt(row[4] ** 2 + row[5] ** 2 + row[6] ** 2))
    if not ends:
        return None
    return plan(np.array(ends)), np.array(speeds) < 0.1


def table(results, args):
    lines = [f"| materials | profile | at rest on the survey | distance P10 / P50 / P90 (m), measured | "
             "simulated P10 / P50 / P90 (m), at rest | simulated 5-95 % (m) | measured P10-P90 inside | "
             "KS (censored) | KS (at rest) | lateral sd (m), measured / simulated |",
             "|---|---|---:|---|---|---|---|---:|---:|---|"]
    for (materials, profile), m in sorted(results.items(), key=lambda kv: (kv[0][1], kv[0][0] != "Rockable")):
        s = m["simulated"]
        inside = s[0] <= m["measured"][0] and m["measured"][2] <= s[4]
        lines.append(
            f"| {materials} | {profile} | {m['rest']} of {m['n']} ({100.0 * m['rest'] / m['n']:.1f} %) | "
            f"{m['measured'][0]:.1f} / {m['measured'][1]:.1f} / {m['measured'][2]:.1f} | "
            f"{s[1]:.1f} / {s[2]:.1f} / {s[3]:.1f} | {s[0]:.1f}-{s[4]:.1f} | {'yes' if inside else 'no'} | "
            f"{m['ks_censored']:.3f} | {m['ks_rest']:.3f} | {m['lateral_sd'][0]:.1f} / {m['lateral_sd'][1]:.1f} |")
    return "\n".join(lines) + "\n"


def plot(results, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    keys = [k for k in results if k[0] != "Rockable"]
    fig, axes = plt.subplots(2, len(keys), figsize=(4.2 * len(keys), 8.0), squeeze=False)
    for k, key in enumerate(keys):
        m = results[key]
        ax = axes[0][k]
        sim, rest = m["plan_simulated"], m["at_rest"]
        ax.scatter(sim[rest, 0], sim[rest, 1], s=3, c="tab:blue", alpha=0.35, label="simulated, at rest")
        ax.scatter(m["plan_measured"][:, 0], m["plan_measured"][:, 1], s=14, c="tab:red", label="measured")
        ax.plot([0], [0], "k^", label="mean drop point")
        ax.set_aspect("equal")
        ax.set_xlabel("x from the mean drop point (m)")
        ax.set_ylabel("y from the mean drop point (m)")
        ax.set_title(f"{key[1]}, {key[0]}: stops in plan")
        ax.legend(fontsize=7, loc="best")
        ax = axes[1][k]
        d_m = np.sort(m["d_m"])
        ax.step(d_m, np.arange(1, len(d_m) + 1) / len(d_m), where="post", color="tab:red", label="measured")
        d_s = np.sort(m["d_s"][rest])
        ax.step(d_s, np.arange(1, len(d_s) + 1) / m["n"], where="post", color="tab:blue",
                label="simulated (share of all realizations)")
        ax.set_xlabel("distance of the stop from the mean drop point (m)")
        ax.set_ylabel("cumulative share")
        ax.set_ylim(0, 1.02)
        ax.set_title(f"KS {m['ks_censored']:.2f} (blocks not at rest count as beyond)", fontsize=9)
        ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    tmp = path + ".tmp.png"
    fig.savefig(tmp, dpi=110)
    os.replace(tmp, path)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", required=True, help="the dataset's folder (a clone of AuthumeQuarryRockfalls_Data-in-Brief)")
    p.add_argument("--bin", default="build/bin", help="folder of the Talus tools")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--realizations", type=int, default=1024, help="per profile and material set (default 1024)")
    p.add_argument("--materials", nargs="+", default=["defaults", "classes"], choices=["defaults", "classes"])
    p.add_argument("--profiles", nargs="+", default=PROFILES, choices=PROFILES)
    p.add_argument("--sigma", type=float, default=0.05, help="roughness sd of the TIN's vertices (m, default 0.05)")
    p.add_argument("--density", type=float, default=2700.0, help="block density (kg/m^3, default 2700)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--threads", type=int, default=0, help="dda-run threads (0: all cores)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="passed to every dda-run (not to calibrate: what both need belongs in the scene)")
    p.add_argument("--calibrate", action="store_true",
                   help="calibrate the classes' zones on each profile (calibrate-P*.yaml) and run both profiles with "
                        "the posterior medians: about 10 min per profile on 2 cores")
    p.add_argument("--calibration", type=int, nargs=3, default=[24, 64, 3],
                   metavar=("PARTICLES", "REALIZATIONS", "GENERATIONS"),
                   help="calibrate-P*.yaml's particles, realizations per simulation and generations (24 64 3)")
    p.add_argument("--law", choices=["scaled", "point"], default="scaled",
                   help="dda-run's restitution law (docs/dda.md, Impact-rebound); default scaled")
    p.add_argument("--material", action="append", default=[], metavar="CLASS:KEY=VALUE",
                   help="with the classes: a property of the zones of that class (e.g. soil:ploughing=0.3)")
    args = p.parse_args()
    if args.calibrate and ("classes" not in args.materials or len(args.profiles) != 2):
        fail("--calibrate needs the classes and both profiles")
    if args.realizations < 1:
        fail("--realizations must be at least 1")
    if not os.path.isdir(args.data):
        fail(f"{args.data}: not a folder (clone the dataset first; see --help)")
    os.makedirs(args.out, exist_ok=True)
    log = os.path.join(args.out, "log.txt")
    terrain, blocks = build(args, args.out, log)
    profiles = [read_profile(args, name) for name in args.profiles]
    results = {}
    for profile in profiles:
        peer = rockable(args, profile.name)
        if peer is not None:
            results[("Rockable", profile.name)] = measure(profile, *peer)
    threads = ["--threads", str(args.threads)] if args.threads > 0 else []

    def simulate(path, key, profile):
        run_file = os.path.splitext(path)[0] + ".h5"
        cmd = [os.path.join(args.bin, "dda-run"), "-c", path, "-q", "-o", run_file] + threads
        for kv in args.set:
            cmd += ["--set", kv]
        run(cmd, log)
        results[key] = measure(profile, *read_run(run_file))

    for materials in args.materials:
        for profile in profiles:
            path = scene(args, args.out, terrain, blocks, profile, materials)
            if materials == "classes":
                calibration_files(args, args.out, profile)
            simulate(path, (materials, profile.name), profile)
    # Each profile's calibration predicts the other: its posterior medians beside the classes.
    if args.calibrate:
        for fit in profiles:
            fit_dir = os.path.join(args.out, f"fit-{fit.name}")
            run([os.path.join(args.bin, "calibrate"), "-c", os.path.join(args.out, f"calibrate-{fit.name}.yaml"),
                 "-o", fit_dir] + threads, log)
            fitted = fitted_medians(os.path.join(fit_dir, "summary.csv"))
            for profile in profiles:
                name = f"calibrated-on-{fit.name}"
                path = scene(args, args.out, terrain, blocks, profile, "classes", fitted, name)
                simulate(path, (f"calibrated on {fit.name}", profile.name), profile)
    text = table(results, args)
    with open(os.path.join(args.out, "table.md"), "w") as f:
        f.write(text)
    plot(results, os.path.join(args.out, "stops.png"))
    sys.stdout.write(text)


if __name__ == "__main__":
    main()
