#!/usr/bin/python3
"""Synthetic recovery test of calibrate against published summaries (docs/calibration.md,
"Summary statistics"), through the tools.

The stops of drop points A and B of samples/calibration are made by dda-run with known
ground parameters (restitution_mean 0.59, friction angle 35 deg), then reduced to what a
report would publish: the share of blocks past 60 m (a count of n), runout and lateral
quantiles with their standard errors, the farthest block of n. calibrate fits both
parameters to drop point A's summaries alone, then predicts drop point B's. Checked:

- each true value lies inside the posterior's [P5, P95] (summary.csv);
- the summaries taught something: the friction angle's posterior sd is below the prior's,
  and the tolerance fell from generation to generation;
- the same calibration on one thread gives the posterior of two threads, byte for byte;
- drop point B's published statistics lie inside their predictive bands (all but one).

Usage: calibration_summaries.py --bin BUILD/bin [--keep DIR]
Exit 0 on success, 1 on a failed check. Needs NumPy and h5py (Debian's python3 has both)
to reduce the run files to summaries.
"""
import argparse
import csv
import os
import shutil
import subprocess
import sys
import tempfile

import h5py
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SAMPLE = os.path.join(ROOT, "samples", "calibration")
TRUTH = {"ground.restitution_mean": 0.59, "ground.friction_angle_mean_deg": 35.0}
BLOCKS = 60          # blocks of each drop test, the n of its published maximum
PAST = 60.0          # m: the line whose share is published


def summaries(run):
    """A report's summaries of a run file: every block, wherever it ended (docs/calibration.md)."""
    with h5py.File(run, "r") as f:
        runout, lateral = f["records/runout"][()], f["records/lateral"][()]
    n = len(runout)

    def quantile(x, p):
        # The standard error of a quantile: half the spread of the order statistics one
        # binomial sd either side, as calibrate estimates the simulation's.
        s = (p * (1 - p) / n) ** 0.5
        sd = (np.quantile(x, min(1.0, p + s)) - np.quantile(x, max(0.0, p - s))) / 2
        return "{statistic: quantile, variable: %s, p: %g, value: %.3f, sd: %.3f}" % (
            "runout" if x is runout else "lateral", p, np.quantile(x, p), max(sd, 0.1))

    items = ["{statistic: share_above, variable: runout, threshold: %g, count: %d, n: %d}" % (PAST, np.sum(runout > PAST), n)]
    items += [quantile(runout, p) for p in (0.1, 0.5, 0.9)] + [quantile(lateral, p) for p in (0.1, 0.9)]
    items.append("{statistic: max, variable: runout, n: %d, value: %.3f, sd: 0.5}" % (n, runout.max()))
    return "[" + ", ".join(items) + "]"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bin", required=True)
    ap.add_argument("--keep", default="")
    args = ap.parse_args()
    work = args.keep or tempfile.mkdtemp(prefix="talus-calibration-summaries-")
    os.makedirs(work, exist_ok=True)
    failures = []

    def tool(name, *argv):
        cmd = [os.path.join(args.bin, name)] + list(argv)
        r = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
        if r.returncode != 0:
            sys.exit("calibration_summaries: %s exited %d: %s" % (" ".join(cmd), r.returncode, r.stderr.strip()[-600:]))
        return r

    terrain, blocks = os.path.join(work, "terrain.h5"), os.path.join(work, "blocks.h5")
    tool("terrain-gen", "-c", os.path.join(SAMPLE, "terrain.yaml"), "-o", terrain, "-q")
    tool("block-gen", "-c", os.path.join(SAMPLE, "blocks.yaml"), "-o", blocks, "-q")
    paths = ["--set", "terrain=" + terrain, "--set", "block_file=" + blocks]
    truth = "materials=[{name: ground, restitution_mean: 0.59, friction_angle_mean_deg: 35}]"
    obs_a, obs_b = os.path.join(work, "observed-A.h5"), os.path.join(work, "observed-B.h5")
    tool("dda-run", "-c", os.path.join(SAMPLE, "drop.yaml"), *paths, "--set", "seed=101", "--set", truth,
         "--set", "realizations=%d" % BLOCKS, "-o", obs_a, "-q")
    tool("dda-run", "-c", os.path.join(SAMPLE, "drop.yaml"), *paths, "--set", "seed=102", "--set", truth,
         "--set", "realizations=%d" % BLOCKS, "--set", "release.points=[[20, 50]]", "-o", obs_b, "-q")

    common = ["-c", os.path.join(SAMPLE, "summaries.yaml"),
              "--set", "set=[terrain=%s, block_file=%s]" % (terrain, blocks),
              "--set", "groups[0].summaries=" + summaries(obs_a), "--set", "plots=false",
              "--set", "particles=20", "--set", "generations=2", "--set", "realizations=%d" % BLOCKS]
    fit, again = os.path.join(work, "fit"), os.path.join(work, "fit-1-thread")
    tool("calibrate", *common, "-o", fit, "--threads", "2", "-q")
    tool("calibrate", *common, "-o", again, "--threads", "1", "-q")
    for name in ("posterior.csv", "generations.csv", "summary.csv"):
        with open(os.path.join(fit, name)) as a, open(os.path.join(again, name)) as b:
            if a.read() != b.read():
                failures.append("%s differs between 2 threads and 1" % name)

    with open(os.path.join(fit, "summary.csv")) as f:
        rows = {r["parameter"]: r for r in csv.DictReader(f)}
    for name, true in TRUTH.items():
        r = rows[name]
        p5, p50, p95 = float(r["P5"]), float(r["P50"]), float(r["P95"])
        print("%s: truth %g, posterior P5 %.4g, P50 %.4g, P95 %.4g" % (name, true, p5, p50, p95))
        if not p5 <= true <= p95:
            failures.append("%s: the truth %g is outside the posterior's [P5, P95] = [%.4g, %.4g]" % (name, true, p5, p95))
    friction = rows["ground.friction_angle_mean_deg"]
    prior_sd = (float(friction["max"]) - float(friction["min"])) / 12 ** 0.5
    if not float(friction["sd"]) < prior_sd:
        failures.append("the friction angle's posterior sd %s is not below the prior's %.4g" % (friction["sd"], prior_sd))
    with open(os.path.join(fit, "generations.csv")) as f:
        tolerances = [float(r["tolerance"]) for r in csv.DictReader(f)][1:]
    if not all(b < a for a, b in zip(tolerances, tolerances[1:])):
        failures.append("the tolerance did not fall at every generation: %s" % tolerances)

    predict = os.path.join(work, "predict")
    tool("calibrate", "-c", os.path.join(SAMPLE, "summaries.yaml"),
         "--set", "set=[terrain=%s, block_file=%s, 'release.points=[[20, 50]]']" % (terrain, blocks),
         "--set", "groups[0].name=drop B", "--set", "groups[0].summaries=" + summaries(obs_b), "--set", "plots=false",
         "--set", "realizations=%d" % BLOCKS, "--set", "predictive_draws=40", "--set", "seed=2",
         "--predict", os.path.join(fit, "posterior.h5"), "-o", predict, "-q")
    with open(os.path.join(predict, "predictive.csv")) as f:
        rows = list(csv.DictReader(f))
    inside = sum(int(r["inside"]) for r in rows)
    print("drop B: %d of %d published statistics inside the predictive band" % (inside, len(rows)))
    if len(rows) != 7 or inside < len(rows) - 1:
        failures.append("drop B: only %d of %d statistics inside the predictive band" % (inside, len(rows)))

    if not args.keep:
        shutil.rmtree(work, ignore_errors=True)
    for f in failures:
        print("FAILED: " + f)
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
