#!/usr/bin/python3
# SPDX-License-Identifier: MIT
"""The bench-slope study against the published one (docs/reference-study.md).

  paper.py table DIR [--paper CSV] [--toe X] [-o PAPER.md]
      the paper's figures (paper-figures.csv) beside Talus's, cell by cell, from
      DIR/run-S1.h5 ... run-S3.h5 (dda-run, blocks R1-R4 in turn), with sampling intervals
  paper.py sensitivity --bin DIR --out DIR [--realizations N] [--jobs J] [--only NAME ...]
                       [-o SENSITIVITY.md]
      the study rerun with each model choice changed, the twelve toe shares against the
      defaults' (the runs go to --out; a run file there newer than the tools and inputs it
      is made from is reused)
  paper.py shapes DIR [--also LABEL=DIR ...] [-o SHAPES.md]
      per block and level: bench stops, impacts, energy lost per impact, energy at the toe,
      and (with trajectories) flight and rotation shares; the cube and the octahedron at two
      time steps (DIR/cube-octahedron-{design,research}-S*.h5) when present

  paper.py bands PREDICTDIR [--fit FITDIR] [--figure BANDS.png] [-o BANDS.md]
      the published figures against the predictive bands of a calibration
      (calibrate --predict with samples/bench-slope/predict.yaml: PREDICTDIR/predictive.csv),
      with the posterior of FITDIR (summary.csv, generations.csv) when given

Conventions (stated in docs/reference-study.md): the toe share counts every realization
whose final centroid is at x >= TOE (36 m), those that left the terrain past it included;
the maximum runout is the largest final x of the blocks at rest (x from the crest, the
frame of the toe at 36 m and of the terrain's end at 60 m; the run file's `runout` is
measured from the release point at x = 1 m); the lateral range is over the blocks at rest;
max speed and max jump are over every realization.
Needs h5py and NumPy (Debian python3-h5py python3-numpy).
"""
import argparse
import concurrent.futures
import csv
import math
import os
import subprocess
import sys

import h5py
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
LEVELS = ["S1", "S2", "S3"]
BLOCKS = ["R1", "R2", "R3", "R4"]
R_INDEX = {"S1": 0.125, "S2": 0.25, "S3": 0.5}
Z95 = 1.959963984540054
# Order statistic bounding a repeat's maximum: the K-th largest of n (see order_bound).
K_BOUND = 6
REST, LEFT = 1, 2


def fail(message):
    print("paper.py: error: " + message, file=sys.stderr)
    sys.exit(1)


def text(x):
    return x.decode() if isinstance(x, bytes) else str(x)


def write(path, content):
    if not path or path == "-":
        sys.stdout.write(content)
        return
    tmp = path + ".tmp-paper"
    with open(tmp, "w") as f:
        f.write(content)
    os.replace(tmp, path)


# ---------------------------------------------------------------- statistics

def wilson(k, n, z=Z95):
    """Wilson score interval of a binomial share k/n."""
    if n == 0:
        return float("nan"), float("nan")
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return max(0.0, centre - half), min(1.0, centre + half)


def below_probability(n, m, k):
    """P(the maximum of m new draws < the k-th largest of n) for exchangeable draws:
    the k largest of the n + m pooled values all come from the n, C(n,k)/C(n+m,k)."""
    if n < k:
        return float("nan")
    p = 1.0
    for i in range(k):
        p *= (n - i) / (n + m - i)
    return p


def order_bound(values, largest=True, k=K_BOUND):
    """The k-th largest (or smallest) value: a repeat of the study (as many draws again)
    has its maximum (minimum) beyond it with probability 1 - C(n,k)/C(2n,k)."""
    v = np.sort(np.asarray(values, float))
    if len(v) < k:
        return float("nan")
    return float(v[-k]) if largest else float(v[k - 1])


# ---------------------------------------------------------------- run files

class Run:
    def __init__(self, path):
        if not os.path.exists(path):
            fail("%s: missing (run dda-run first)" % path)
        with h5py.File(path, "r") as f:
            r = f["records"]
            self.block = r["block"][:]
            self.end = r["end_reason"][:].astype(int)
            self.final = r["final_position"][:]
            self.release = r["release_position"][:]
            self.lateral = r["lateral"][:]
            self.max_speed = r["max_speed"][:]
            self.max_jump = r["max_jump_height"][:]
            self.max_normal_jump = r["max_normal_jump_height"][:]
            self.impacts = r["impacts"][:]
            self.time = r["time"][:]
            self.steps = r["steps"][:]
            self.max_ke = r["max_kinetic_energy"][:]
            self.blocks = [text(x) for x in f["run/blocks"][:]]
            self.realization = r["realization"][:]

    def sel(self, block):
        if block not in self.blocks:
            return np.zeros(len(self.block), bool)
        return self.block == self.blocks.index(block)


def load_runs(directory):
    return {level: Run(os.path.join(directory, "run-%s.h5" % level)) for level in LEVELS}


def toe_counts(run, block, toe):
    s = run.sel(block)
    return int(np.sum(run.final[s, 0] >= toe)), int(np.sum(s))


# ---------------------------------------------------------------- table

def read_paper(path):
    values = {}
    with open(path) as f:
        rows = csv.DictReader(line for line in f if not line.startswith("#"))
        for row in rows:
            values.setdefault((row["level"], row["block"], row["quantity"]), {})[row["table"]] = float(row["value"])
    return values


def paper_value(paper, level, block, quantity):
    """The paper's value; where two of its tables give one, the first listed (both are printed
    when they differ)."""
    entry = paper.get((level, block, quantity))
    if not entry:
        return None, ""
    vals = list(entry.values())
    other = "" if all(abs(v - vals[0]) < 1e-9 for v in vals) else " (also %s)" % "/".join("%g" % v for v in vals[1:])
    return vals[0], other


def f1(x, d=1):
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else "%.*f" % (d, x)


def largest(values):
    return float(np.max(values)) if len(values) else float("nan")


def cell_figures(run, block, toe):
    s = run.sel(block)
    rest = s & (run.end == REST)
    k, n = toe_counts(run, block, toe)
    lo, hi = wilson(k, n)
    x_rest = run.final[rest, 0]
    lat = run.lateral[rest]
    return {
        "n": n, "k": k, "share": k / n if n else float("nan"), "share_lo": lo, "share_hi": hi,
        "left": int(np.sum(s & (run.end == LEFT))),
        "left_far": int(np.sum(s & (run.end == LEFT) & (run.final[:, 0] >= 59.0))),
        "other_end": int(np.sum(s & (run.end != REST) & (run.end != LEFT))),
        "n_rest": int(np.sum(rest)),
        "max_runout": largest(x_rest),
        "max_runout_bound": order_bound(x_rest),
        "lat_min": -largest(-lat), "lat_max": largest(lat),
        "lat_min_bound": order_bound(lat, largest=False),
        "lat_max_bound": order_bound(lat),
        "max_speed": largest(run.max_speed[s]), "max_speed_bound": order_bound(run.max_speed[s]),
        "max_jump": largest(run.max_jump[s]), "max_jump_bound": order_bound(run.max_jump[s]),
        "max_normal_jump": largest(run.max_normal_jump[s]),
    }


def verdict_share(p, c):
    if p is None:
        return ""
    if math.isnan(c["share_lo"]):
        return "–"
    return "yes" if c["share_lo"] <= p / 100 <= c["share_hi"] else "no"


def verdict_max(p, value, bound):
    """'no' when the paper's maximum is below the bound (a repeat's maximum falls there with
    probability C(n,6)/C(2n,6), about 1.5 % at n = 250); 'above' when it exceeds Talus's maximum
    (a repeat does that with probability 1/2: not resolved); else 'yes'."""
    if p is None:
        return ""
    if math.isnan(bound):
        return "–"
    if p < bound:
        return "no"
    return "above" if p > value else "yes"


def cmd_table(args):
    paper = read_paper(args.paper)
    runs = load_runs(args.dir)
    cells = {(l, b): cell_figures(runs[l], b, args.toe) for l in LEVELS for b in BLOCKS}
    n = cells[("S1", "R1")]["n"]
    out = []
    out.append("| cell | toe share (%): paper | Talus [95 % Wilson] | paper inside | max runout (m): paper | Talus [bound] | paper inside | left the terrain (past x = 59 m) | lateral width (m): paper | Talus [bound] | paper inside |")
    out.append("|---|---|---|---|---|---|---|---|---|---|---|")
    for l in LEVELS:
        for b in BLOCKS:
            c = cells[(l, b)]
            pt, pt_other = paper_value(paper, l, b, "toe_share")
            pr, pr_other = paper_value(paper, l, b, "max_runout")
            pw, pw_other = paper_value(paper, l, b, "lateral_width")
            width = c["lat_max"] - c["lat_min"]
            width_bound = c["lat_max_bound"] - c["lat_min_bound"]
            out.append("| %s %s | %s | %s [%s, %s] | %s | %s | %s [≥ %s] | %s | %d (%d) | %s | %s [≥ %s] | %s |" % (
                l, b, f1(pt) + pt_other if pt is not None else "–",
                f1(100 * c["share"]), f1(100 * c["share_lo"]), f1(100 * c["share_hi"]), verdict_share(pt, c),
                f1(pr, 2) + pr_other if pr is not None else "–",
                f1(c["max_runout"]), f1(c["max_runout_bound"]),
                verdict_max(pr, c["max_runout"], c["max_runout_bound"]),
                c["left"], c["left_far"],
                f1(pw, 2) + pw_other if pw is not None else "–", f1(width), f1(width_bound),
                verdict_max(pw, width, width_bound)))
    out.append("")
    out.append("| cell | lateral range (m): paper | Talus [bounds] | max speed (m/s): paper | Talus [bound] | paper inside | max jump (m): paper | Talus vertical [bound] / normal | paper inside |")
    out.append("|---|---|---|---|---|---|---|---|---|")
    for l in LEVELS:
        for b in BLOCKS:
            c = cells[(l, b)]
            lo, lo_other = paper_value(paper, l, b, "lateral_min")
            if lo is None:
                continue
            hi, hi_other = paper_value(paper, l, b, "lateral_max")
            ps, _ = paper_value(paper, l, b, "max_speed")
            pj, _ = paper_value(paper, l, b, "max_jump")
            out.append("| %s %s | [%s%s, %s] | [%s, %s] [≤ %s, ≥ %s] | %s | %s [≥ %s] | %s | %s | %s [≥ %s] / %s | %s |" % (
                l, b, f1(lo, 2), lo_other, f1(hi, 2), f1(c["lat_min"]), f1(c["lat_max"]),
                f1(c["lat_min_bound"]), f1(c["lat_max_bound"]),
                f1(ps, 2), f1(c["max_speed"]), f1(c["max_speed_bound"]),
                verdict_max(ps, c["max_speed"], c["max_speed_bound"]),
                f1(pj, 2), f1(c["max_jump"], 2), f1(c["max_jump_bound"], 2), f1(c["max_normal_jump"], 2),
                verdict_max(pj, c["max_jump"], c["max_jump_bound"])))
    ins = sum(verdict_share(paper_value(paper, l, b, "toe_share")[0], cells[(l, b)]) == "in"
              for l in LEVELS for b in BLOCKS)
    given = sum(paper_value(paper, l, b, "toe_share")[0] is not None for l in LEVELS for b in BLOCKS)
    out.append("")
    out.append("%d realizations per cell (the first cell's); toe shares: %d of the paper's %d inside "
               "Talus's 95 %% interval. A repeat's maximum falls below the 6th largest of n with probability "
               "C(n,6)/C(2n,6) = %.3f at n = %d; a repeat's lateral width falls below its bound (6th largest minus "
               "6th smallest) with probability at most twice that." % (n, ins, given, below_probability(n, n, K_BOUND), n))
    write(args.output, "\n".join(out) + "\n")


# ---------------------------------------------------------------- sensitivity

# Each variant: (name, what it changes, terrain-gen --set list, dda-run --set list).
# {R} is the level's roughness index. Materials are overridden by name in the scene
# (the terrain's material is 'slope').
def mat(**fields):
    return "materials=[{name: slope, %s}]" % ", ".join("%s: %s" % kv for kv in fields.items())


VARIANTS = [
    ("defaults", "SPEC §4 ground, σ = 0.8 R, alternating cut, rigid6", [], []),
    ("friction 20°", "friction_angle_mean_deg 10 → 20", [], [mat(friction_angle_mean_deg=20)]),
    ("friction 30°", "friction_angle_mean_deg 10 → 30", [], [mat(friction_angle_mean_deg=30)]),
    ("friction sd 0", "friction_coefficient_sd 0.05 → 0", [], [mat(friction_coefficient_sd=0)]),
    ("friction sd 0.15", "friction_coefficient_sd 0.05 → 0.15", [], [mat(friction_coefficient_sd=0.15)]),
    ("R_v 0.85", "restitution_mean 0.95 → 0.85", [], [mat(restitution_mean=0.85)]),
    ("R_v 0.75", "restitution_mean 0.95 → 0.75", [], [mat(restitution_mean=0.75)]),
    ("R_v sd 0.15", "restitution_sd 0.05 → 0.15", [], [mat(restitution_sd=0.15)]),
    ("K 6 m/s", "restitution_scale 12 → 6 m/s", [], [mat(restitution_scale=6)]),
    ("K 24 m/s", "restitution_scale 12 → 24 m/s", [], [mat(restitution_scale=24)]),
    ("tilt 5°", "lateral_tilt_sd_deg 0 → 5", [], [mat(lateral_tilt_sd_deg=5)]),
    ("tilt 15°", "lateral_tilt_sd_deg 0 → 15", [], [mat(lateral_tilt_sd_deg=15)]),
    ("σ = 0.4 R", "roughness σ halved (0.05 / 0.1 / 0.2 m)", ["roughness.roughness_index=~", "roughness.sigma={half}"], []),
    ("σ = 1.6 R", "roughness σ doubled (0.2 / 0.4 / 0.8 m; a release in the ground lifted clear)",
     ["roughness.roughness_index=~", "roughness.sigma={double}"], ["release.clearance=lift"]),
    ("rest 0.05 J/kg", "rest_kinetic_energy 0.001 → 0.05 J/kg (0.32 m/s)", [], ["engine.rest_kinetic_energy=0.05"]),
    ("rest dwell 0.1 s", "rest_dwell 0.5 → 0.1 s", [], ["engine.rest_dwell=0.1"]),
    ("35 s limit", "max_time 132 s → 35 s (35 000 steps of 1 ms)", [], ["engine.max_time=35"]),
    ("35 000 steps", "max_steps 0 → 35 000 accepted steps", [], ["engine.max_steps=35000"]),
    ("full12", "dof rigid6 → full12", [], ["engine.dof=full12"]),
    ("fixed cut", "triangulation alternating → fixed", ["triangulation=fixed"], []),
    ("normal-component law", "restitution scaled → normal_component", [], ["engine.restitution=normal_component"]),
    ("no normal-approach bound", "restitution_bound normal_approach → none", [], ["engine.restitution_bound=none"]),
]


def slug(name):
    name = name.replace("σ", "sigma").replace("°", "deg")
    return "-".join("".join(c if c.isascii() and c.isalnum() else " " for c in name).lower().split())


def stale(path, deps):
    """A file to (re)make: missing, or older than what it is made from."""
    return not os.path.exists(path) or os.path.getmtime(path) < max(os.path.getmtime(d) for d in deps)


def run_variant_level(args, variant, level):
    name, _, tsets, dsets = variant
    d = os.path.join(args.out, slug(name))
    os.makedirs(d, exist_ok=True)
    sigma = 0.8 * R_INDEX[level]
    subs = {"R": R_INDEX[level], "half": sigma / 2, "double": sigma * 2}
    terrain = os.path.join(d, "terrain-%s.h5" % level)
    run = os.path.join(d, "run-%s.h5" % level)
    nice = ["nice", "-n", str(args.nice)] if args.nice else []
    terrain_gen, dda_run = os.path.join(args.bin, "terrain-gen"), os.path.join(args.bin, "dda-run")
    if stale(terrain, [terrain_gen, os.path.join(HERE, "terrain.yaml")]):
        cmd = nice + [terrain_gen, "-q", "-c", os.path.join(HERE, "terrain.yaml"),
                      "--set", "seed=%d" % args.seed]
        if not any(s.startswith("roughness.") for s in tsets):
            cmd += ["--set", "roughness.roughness_index=%g" % R_INDEX[level]]
        for s in tsets:
            cmd += ["--set", s.format(**subs)]
        subprocess.run(cmd + ["-o", terrain], check=True)
    if stale(run, [dda_run, terrain, args.blocks, os.path.join(HERE, "scene.yaml")]):
        cmd = nice + [dda_run, "-q", "-c", os.path.join(HERE, "scene.yaml"),
                      "--set", "terrain=" + terrain, "--set", "block_file=" + args.blocks,
                      "--set", "realizations=%d" % args.realizations, "--set", "seed=%d" % args.seed,
                      "--threads", "1"]
        for s in dsets:
            cmd += ["--set", s]
        done = subprocess.run(cmd + ["-o", run + ".tmp.h5"], stderr=subprocess.PIPE, text=True)
        if done.returncode != 0 or not os.path.exists(run + ".tmp.h5"):
            fail("%s: dda-run exited %d: %s" % (run, done.returncode, done.stderr.strip()[-400:]))
        os.replace(run + ".tmp.h5", run)
    return run


def cmd_sensitivity(args):
    variants = [v for v in VARIANTS if not args.only or v[0] in args.only or v[0] == "defaults"]
    os.makedirs(args.out, exist_ok=True)
    args.blocks = os.path.join(args.out, "platonic.h5")
    if stale(args.blocks, [os.path.join(args.bin, "block-gen"), os.path.join(ROOT, "samples", "blocks", "platonic.yaml")]):
        subprocess.run([os.path.join(args.bin, "block-gen"), "-q", "-c",
                        os.path.join(ROOT, "samples", "blocks", "platonic.yaml"), "-o", args.blocks], check=True)
    jobs = [(v, l) for v in variants for l in LEVELS]
    with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
        files = dict(zip([(v[0], l) for v, l in jobs], pool.map(lambda j: run_variant_level(args, *j), jobs)))
    shares, ends = {}, {}
    for v in variants:
        for l in LEVELS:
            r = Run(files[(v[0], l)])
            for b in BLOCKS:
                k, n = toe_counts(r, b, args.toe)
                shares[(v[0], l, b)] = 100.0 * k / n if n else float("nan")
            ends[(v[0], l)] = (int(np.sum(r.end == LEFT)), int(np.sum((r.end != REST) & (r.end != LEFT))))
    cells = [(l, b) for l in LEVELS for b in BLOCKS]
    head = "| choice | change | " + " | ".join("%s %s" % c for c in cells) + \
        " | mean shift (pp) | largest shift (pp) | left / other ends |"
    out = [head, "|" + "---|" * (len(cells) + 5)]
    rows = []
    for v in variants:
        sh = [shares[(v[0],) + c] for c in cells]
        d = [s - shares[("defaults",) + c] for s, c in zip(sh, cells)]
        left = sum(ends[(v[0], l)][0] for l in LEVELS)
        other = sum(ends[(v[0], l)][1] for l in LEVELS)
        rows.append((v, sh, d, left, other))
    base = rows[0]
    order = [base] + sorted(rows[1:], key=lambda r: -abs(np.mean(r[2])))
    for v, sh, d, left, other in order:
        if v[0] == "defaults":
            cells_text = " | ".join("%.1f" % s for s in sh)
            out.append("| **%s** | %s | %s | | | %d / %d |" % (v[0], v[1], cells_text, left, other))
        else:
            cells_text = " | ".join("%+.1f" % x for x in d)
            # Standard error of the mean shift as if the two runs were independent samples
            # (common random numbers make it smaller for changes that leave trajectories alone).
            p0 = np.array([shares[("defaults",) + c] for c in cells]) / 100
            p1 = np.array(sh) / 100
            n_cell = args.realizations / len(BLOCKS)
            se = math.sqrt(np.sum(p0 * (1 - p0) / n_cell + p1 * (1 - p1) / n_cell)) / len(cells) * 100
            out.append("| %s | %s | %s | %+.1f ± %.1f | %+.1f | %d / %d |" % (
                v[0], v[1], cells_text, np.mean(d), se, max(d, key=abs), left, other))
    out.append("")
    out.append("Defaults row: toe shares (%%, final centroid at x ≥ %g m); other rows: the shift from it in "
               "percentage points (mean shift ± its standard error for two independent samples per cell); %d realizations per level (%d per block), seed %d for every run; rows by |mean "
               "shift|. Last column: realizations of the three levels that left the terrain / ended otherwise "
               "than at rest or off the terrain (step or time limit)." % (args.toe, args.realizations,
                                                                          args.realizations // 4, args.seed))
    pairs = [(v[0], l) for v in variants for l in LEVELS]
    cube_ahead = sum(shares[(v, l, "R2")] > shares[(v, l, "R3")] for v, l in pairs)
    ordered = sum(all(shares[(v, l, a)] < shares[(v, l, b)] for a, b in zip(BLOCKS, BLOCKS[1:])) for v, l in pairs)
    out.append("")
    out.append("Shape order over the %d runs (choice and level): the cube (R2) passes the toe more often than the "
               "octahedron (R3) in %d; the toe share rises strictly from R1 to R4, the published order, in %d."
               % (len(pairs), cube_ahead, ordered))
    write(args.output, "\n".join(out) + "\n")


# ---------------------------------------------------------------- shapes

MASS = 2800.0  # kg: 1 m^3 at the SPEC §4 density
G = 9.81


def trajectory_measures(path, run, toe):
    """Per realization, from the sampled trajectory: the share of the sampled time on the slope
    (x < toe), from the first touch on, spent in free flight (acceleration within 1 m/s^2 of
    gravity between two samples), and the rotational share of the kinetic energy there (samples above 1 kJ).
    None when the run file has no trajectories."""
    with h5py.File(path, "r") as f:
        t = f["trajectories"]
        if t["time"].shape[0] == 0:
            return None
        real, time, pos, vel, energy = (t["realization"][:], t["time"][:], t["position"][:],
                                        t["velocity"][:], t["energy"][:])
    flight = np.full(len(run.block), np.nan)
    rot = np.full(len(run.block), np.nan)
    index = {int(r): i for i, r in enumerate(run.realization)}
    bounds = np.flatnonzero(np.diff(real)) + 1
    for a, b in zip(np.r_[0, bounds], np.r_[bounds, len(real)]):
        i = index.get(int(real[a]))
        if i is None or b - a < 3:
            continue
        tt, x, v, e = time[a:b], pos[a:b], vel[a:b], energy[a:b]
        dt = np.diff(tt)
        acc = np.diff(v, axis=0) / dt[:, None]
        acc[:, 2] += G
        free = np.linalg.norm(acc, axis=1) < 1.0
        # From the first touch on: the release drop is no flight over the slope.
        touched = np.cumsum(~free) > 0
        on_slope = (x[:-1, 0] < toe) & touched
        if on_slope.any():
            flight[i] = float(np.sum(dt[on_slope & free]) / np.sum(dt[on_slope]))
        ke = e - MASS * G * x[:, 2]
        ke_trans = 0.5 * MASS * np.sum(v * v, axis=1)
        moving = (x[:, 0] < toe) & (ke > 1000.0)
        if moving.any():
            rot[i] = float(np.mean(np.clip((ke[moving] - ke_trans[moving]) / ke[moving], 0, 1)))
    return flight, rot


def toe_crossing_energy(path, run):
    """Kinetic energy (J) at the first crossing of the 'toe' barrier, per record (NaN: none)."""
    out = np.full(len(run.block), np.nan)
    with h5py.File(path, "r") as f:
        names = [text(x) for x in f["run/barriers"][:]]
        if "toe" not in names or f["crossings/realization"].shape[0] == 0:
            return out
        c = f["crossings"]
        sel = c["barrier"][:] == names.index("toe")
        real, ke = c["realization"][:][sel], c["kinetic_energy"][:][sel]
    index = {int(r): i for i, r in enumerate(run.realization)}
    for r, e in zip(real[::-1], ke[::-1]):  # reversed: the first crossing is written last
        if int(r) in index:
            out[index[int(r)]] = e
    return out


def med(x):
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    return float(np.median(x)) if len(x) else float("nan")


def cmd_shapes(args):
    out = shape_table(args.dir, args.toe)
    for label, directory in (a.split("=", 1) for a in args.also):
        out += ["", "With %s:" % label, ""] + shape_table(directory, args.toe)
    out += step_table(args.dir, args.toe)
    write(args.output, "\n".join(out) + "\n")


def shape_table(directory, toe):
    out = ["| cell | toe share (%) | bench stops (%) | impacts, median | energy lost per impact, median (kJ) | "
           "kinetic energy at the toe, median (kJ) | run-out past the toe, median (m) | "
           "run-out friction KE_toe/(m g d), median | flight share on the slope | rotational share of KE on the slope |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    for l in LEVELS:
        path = os.path.join(directory, "run-%s.h5" % l)
        r = Run(path)
        traj = trajectory_measures(path, r, toe)
        ke_toe = toe_crossing_energy(path, r)
        for b in BLOCKS:
            s = r.sel(b)
            if not s.any():
                continue
            rest = s & (r.end == REST)
            k, n = toe_counts(r, b, toe)
            bench = rest & (r.final[:, 0] < toe)
            drop = MASS * G * (r.release[rest, 2] - r.final[rest, 2])
            per = drop / np.maximum(r.impacts[rest], 1) / 1000.0
            past = rest & (r.final[:, 0] >= toe)
            d = r.final[past, 0] - toe
            mu = ke_toe[past] / (MASS * G * np.maximum(d, 0.1))
            fl = f1(med(traj[0][s]), 2) if traj else "–"
            ro = f1(med(traj[1][s]), 2) if traj else "–"
            out.append("| %s %s | %.1f | %.1f | %s | %s | %s | %s | %s | %s | %s |" % (
                l, b, 100.0 * k / n, 100.0 * np.sum(bench) / n, f1(med(r.impacts[s]), 0), f1(med(per)),
                f1(med(ke_toe[s]) / 1000.0, 0), f1(med(d)), f1(med(mu), 2), fl, ro))
    return out


def step_table(directory, toe):
    """Toe shares of the cube and the octahedron run alone at the 1 ms and 0.2 ms steps."""
    step_rows = []
    for l in LEVELS:
        files = [os.path.join(directory, "cube-octahedron-%s-%s.h5" % (p, l)) for p in ("design", "research")]
        if not all(os.path.exists(f) for f in files):
            continue
        row = []
        for f in files:
            r = Run(f)
            for b in ("R2", "R3"):
                k, n = toe_counts(r, b, toe)
                lo, hi = wilson(k, n)
                row.append("%.1f [%.1f, %.1f]" % (100.0 * k / n, 100 * lo, 100 * hi))
            k2, n2 = toe_counts(r, "R2", toe)
            k3, n3 = toe_counts(r, "R3", toe)
            p2, p3 = k2 / n2, k3 / n3
            row.append("%+.1f ± %.1f" % (100 * (p2 - p3), 100 * math.sqrt(p2 * (1 - p2) / n2 + p3 * (1 - p3) / n3)))
        step_rows.append("| %s | %s |" % (l, " | ".join(row)))
    if not step_rows:
        return []
    return ["", "| level | cube, 1 ms (%) | octahedron, 1 ms (%) | cube − octahedron, 1 ms (pp) | "
            "cube, 0.2 ms (%) | octahedron, 0.2 ms (%) | cube − octahedron, 0.2 ms (pp) |",
            "|---|---|---|---|---|---|---|"] + step_rows


# ---------------------------------------------------------------- calibration bands

# calibrate's statistic labels (samples/bench-slope/predict.yaml) and how the table names them.
BAND_QUANTITIES = [
    ("share_above runout > 36 m", "toe share (%)", 100.0),
    ("max runout of 250 (m)", "max runout (m)", 1.0),
    ("min lateral of 250 (m)", "lateral min (m)", 1.0),
    ("max lateral of 250 (m)", "lateral max (m)", 1.0),
    ("max speed of 250 (m/s)", "max speed (m/s)", 1.0),
    ("max jump of 250 (m)", "max jump (m)", 1.0),
]
CALIBRATED_CELL = "S1 R4"


def read_bands(path):
    rows = {}
    with open(path) as f:
        for r in csv.DictReader(f):
            rows[(r["case"], r["statistic"])] = r
    return rows


def cmd_bands(args):
    rows = read_bands(os.path.join(args.predictdir, "predictive.csv"))
    cells = [l + " " + b for l in LEVELS for b in BLOCKS]
    out = []
    if args.fit:
        with open(os.path.join(args.fit, "summary.csv")) as f:
            summary = list(csv.DictReader(f))
        with open(os.path.join(args.fit, "generations.csv")) as f:
            gens = list(csv.DictReader(f))
        out.append("| parameter | unit | prior | P5 | P50 | P95 |")
        out.append("|---|---|---|---|---|---|")
        for r in summary:
            out.append("| %s | %s | %s [%s, %s] | %.3g | %.3g | %.3g |" % (
                r["parameter"], r["unit"], r["prior"], r["min"], r["max"], float(r["P5"]), float(r["P50"]),
                float(r["P95"])))
        out.append("")
        out.append("%d generation(s) after the prior, %d simulations; tolerance %s." % (
            len(gens) - 1, sum(int(g["proposed"]) for g in gens),
            " → ".join("%.3g" % float(g["tolerance"]) for g in gens[1:])))
        out.append("")
    out.append("| cell | " + " | ".join(q[1] for q in BAND_QUANTITIES) + " |")
    out.append("|---|" + "---|" * len(BAND_QUANTITIES))
    counts = {"calibrated": [0, 0], "predicted": [0, 0]}
    for cell in cells:
        entries = []
        for label, _, scale in BAND_QUANTITIES:
            r = rows.get((cell, label))
            if r is None:
                entries.append("–")
                continue
            inside = r["inside"] == "1"
            kind = "calibrated" if cell == CALIBRATED_CELL else "predicted"
            counts[kind][0] += inside
            counts[kind][1] += 1
            value = float(r["observed"]) * scale
            entries.append("%s%s%s [%s, %s, %s]" % (
                "" if inside else "**", f1(value, 2 if scale == 1.0 else 1), "" if inside else "**",
                f1(float(r["band_low"]) * scale), f1(float(r["band_median"]) * scale), f1(float(r["band_high"]) * scale)))
        out.append("| %s%s | %s |" % (cell, " (calibrated)" if cell == CALIBRATED_CELL else "", " | ".join(entries)))
    out.append("")
    out.append("Published value in [P5, P50, P95] of the predictive band (%s draws of the posterior, 250 blocks each); "
               "bold: outside the band. Inside: %d of the calibrated cell's %d; %d of the other eleven cells' %d." % (
                   args.draws, counts["calibrated"][0], counts["calibrated"][1], counts["predicted"][0],
                   counts["predicted"][1]))
    write(args.output, "\n".join(out) + "\n")
    if args.figure:
        bands_figure(rows, cells, args.figure)


def bands_figure(rows, cells, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.lines
    import matplotlib.patches
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(2, 3, figsize=(13, 7.5))
    fig.subplots_adjust(left=0.05, right=0.99, bottom=0.14, top=0.91, hspace=0.4, wspace=0.2)
    x = np.arange(len(cells))
    for ax, (label, name, scale) in zip(axes.flat, BAND_QUANTITIES):
        for k, cell in enumerate(cells):
            r = rows.get((cell, label))
            if r is None:
                continue
            lo, med, hi = (float(r[c]) * scale for c in ("band_low", "band_median", "band_high"))
            ax.plot([k, k], [lo, hi], color="C0", linewidth=6, alpha=0.4, solid_capstyle="butt")
            ax.plot([k - 0.25, k + 0.25], [med, med], color="C0", linewidth=1.5)
            inside = r["inside"] == "1"
            ax.plot([k], [float(r["observed"]) * scale], "o" if inside else "X", color="k" if inside else "C3",
                    markersize=6)
        ax.axvspan(cells.index(CALIBRATED_CELL) - 0.5, cells.index(CALIBRATED_CELL) + 0.5, color="0.92", zorder=0)
        ax.set_xticks(x, [c.replace(" ", "\n") for c in cells], fontsize="x-small")
        ax.set_xlim(-0.6, len(cells) - 0.4)
        ax.set_title(name, fontsize="medium")
    handles = [matplotlib.lines.Line2D([], [], color="C0", linewidth=6, alpha=0.4, label="predictive P5-P95 (P50 line)"),
               matplotlib.lines.Line2D([], [], color="k", marker="o", linestyle="", label="published, inside"),
               matplotlib.lines.Line2D([], [], color="C3", marker="X", linestyle="", label="published, outside"),
               matplotlib.patches.Patch(color="0.92", label="the calibrated cell")]
    fig.legend(handles=handles, loc="lower center", ncol=4, fontsize="small")
    fig.suptitle("Calibrated on R4 / S1 alone: the published figures against the predictive bands")
    tmp = path + ".tmp-paper.png"
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    os.replace(tmp, path)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = p.add_subparsers(dest="command", required=True)
    t = sub.add_parser("table")
    t.add_argument("dir")
    t.add_argument("--paper", default=os.path.join(HERE, "paper-figures.csv"))
    t.add_argument("--toe", type=float, default=36.0)
    t.add_argument("-o", "--output", default="-")
    t.set_defaults(func=cmd_table)
    s = sub.add_parser("sensitivity")
    s.add_argument("--bin", default=os.path.join(ROOT, "build", "bin"))
    s.add_argument("--out", default=os.path.join(HERE, "out", "sensitivity"))
    s.add_argument("--realizations", type=int, default=1000)
    s.add_argument("--seed", type=int, default=1)
    s.add_argument("--jobs", type=int, default=2)
    s.add_argument("--nice", type=int, default=10)
    s.add_argument("--toe", type=float, default=36.0)
    s.add_argument("--only", nargs="*", default=[])
    s.add_argument("-o", "--output", default="-")
    s.set_defaults(func=cmd_sensitivity)
    h = sub.add_parser("shapes")
    h.add_argument("dir")
    h.add_argument("--toe", type=float, default=36.0)
    h.add_argument("--also", action="append", default=[], metavar="LABEL=DIR",
                   help="another study's run files, tabled after the first")
    h.add_argument("-o", "--output", default="-")
    h.set_defaults(func=cmd_shapes)
    b = sub.add_parser("bands")
    b.add_argument("predictdir")
    b.add_argument("--fit", default="")
    b.add_argument("--draws", default="40", help="posterior draws of the prediction (for the caption)")
    b.add_argument("--figure", default="")
    b.add_argument("-o", "--output", default="-")
    b.set_defaults(func=cmd_bands)
    args = p.parse_args()
    args.func(args)


if __name__ == "__main__":
    main()
