#!/usr/bin/python3
"""Synthetic recovery test of calibrate (docs/calibration.md), through the tools.

Stops "observed" at two drop points of samples/calibration are made by dda-run with known
ground parameters (restitution_mean 0.59, friction angle 35 deg). calibrate fits both
parameters to drop point A, then predicts drop point B with the posterior. Checked:

- each true value lies inside the posterior's [P5, P95] (summary.csv);
- the data taught something: the friction angle's posterior sd is below the prior's, and
  the tolerance fell from generation to generation;
- drop point B's observed runout quantiles lie inside the predictive band (all but one),
  and the pooled predictive runout is not refused by a KS test at 1 %;
- a calibration killed after its first generation and resumed (on one thread) gives the
  posterior an uninterrupted run (on two threads) gives, byte for byte;
- a simulation budget that runs out during generation 1 is an error, not the prior's
  sample returned as a posterior, and --predict refuses the checkpoint it leaves, and that
  of a calibration killed before its end;
- progress comes as lines per generation (simulations, accepted particles, ETA);
- a calibration whose simulations leave no block at rest stops after generation 0 with
  an error (it never ended);
- compared by the stops' horizontal distance from the drop point alone (variables:
  distance), each true value lies inside the posterior's [P5, P95] too;
- with --mpiexec (a build with MPI), the same calibration on 2 MPI ranks of one thread
  gives that posterior too.

Usage: calibration_recovery.py --bin BUILD/bin [--quick | --sanitized] [--mpiexec MPIEXEC] [--keep DIR]
Without an option: the benchmark version (docs/benchmarks.md); --quick: the CI version;
--sanitized: the chain of tools at a tenth of the cost, for sanitizer builds (about ten
times slower): the same commands and the resume check, but too few particles and
realizations for the statistical checks, which it leaves out.
Exit 0 on success, 1 on a failed check.
Only the standard library is used (the tools write CSV).
"""
import argparse
import csv
import os
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SAMPLE = os.path.join(ROOT, "samples", "calibration")
TRUTH = {"ground.restitution_mean": 0.59, "ground.friction_angle_mean_deg": 35.0}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bin", required=True)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--sanitized", action="store_true")
    ap.add_argument("--mpiexec", default="", help="MPI launcher: also run the fit on 2 ranks")
    ap.add_argument("--keep", default="")
    args = ap.parse_args()
    work = args.keep or tempfile.mkdtemp(prefix="talus-calibration-")
    os.makedirs(work, exist_ok=True)
    failures = []

    def tool(name, *argv, env=None, expect=0, launcher=()):
        cmd = list(launcher) + [os.path.join(args.bin, name)] + list(argv)
        r = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
        if r.returncode != expect:
            sys.exit("calibration_recovery: %s exited %d (expected %d): %s" % (" ".join(cmd), r.returncode, expect,
                                                                              r.stderr.strip()[-600:]))
        return r

    terrain, blocks = os.path.join(work, "terrain.h5"), os.path.join(work, "blocks.h5")
    tool("terrain-gen", "-c", os.path.join(SAMPLE, "terrain.yaml"), "-o", terrain, "-q")
    tool("block-gen", "-c", os.path.join(SAMPLE, "blocks.yaml"), "-o", blocks, "-q")
    paths = ["--set", "terrain=" + terrain, "--set", "block_file=" + blocks]
    truth = "materials=[{name: ground, restitution_mean: 0.59, friction_angle_mean_deg: 35}]"
    obs_a, obs_b = os.path.join(work, "observed-A.h5"), os.path.join(work, "observed-B.h5")
    n_obs = "20" if args.sanitized else "40" if args.quick else "60"
    tool("dda-run", "-c", os.path.join(SAMPLE, "drop.yaml"), *paths, "--set", "seed=101", "--set", truth,
         "--set", "realizations=" + n_obs, "-o", obs_a, "-q")
    tool("dda-run", "-c", os.path.join(SAMPLE, "drop.yaml"), *paths, "--set", "seed=102", "--set", truth,
         "--set", "realizations=" + n_obs, "--set", "release.points=[[20, 50]]", "-o", obs_b, "-q")

    size = ["particles=6", "generations=1", "realizations=8"] if args.sanitized else \
           ["particles=12", "generations=2", "realizations=20"] if args.quick else \
           ["particles=24", "generations=3", "realizations=30"]
    common = ["-c", os.path.join(SAMPLE, "calibrate.yaml"),
              "--set", "set=[terrain=%s, block_file=%s]" % (terrain, blocks),
              "--set", "groups[0].observed=" + obs_a, "--set", "plots=false"]
    for kv in size:
        common += ["--set", kv]
    fit = os.path.join(work, "fit")
    tool("calibrate", *common, "-o", fit, "--threads", "2", "-q")

    # Interrupted after generation 1, resumed on one thread: the same posterior.
    resumed = os.path.join(work, "resumed")
    env = dict(os.environ, TALUS_CALIBRATE_ABORT_AFTER_GENERATION="1")
    tool("calibrate", *common, "-o", resumed, "--threads", "2", "-q", env=env, expect=137)
    interrupted = os.path.join(work, "interrupted-posterior.h5")
    shutil.copyfile(os.path.join(resumed, "posterior.h5"), interrupted)
    tool("calibrate", *common, "-o", resumed, "--threads", "1", "--resume", "-q")
    others = [("resumed", resumed)]
    if args.mpiexec:
        ranked = os.path.join(work, "mpi")
        tool("calibrate", *common, "-o", ranked, "--threads", "1", "-q",
             launcher=(args.mpiexec, "--allow-run-as-root", "--oversubscribe", "-n", "2"))
        others.append(("run on 2 MPI ranks", ranked))
    for label, other in others:
        for name in ("posterior.csv", "generations.csv", "summary.csv"):
            with open(os.path.join(fit, name)) as a, open(os.path.join(other, name)) as b:
                if a.read() != b.read():
                    failures.append("%s differs between the uninterrupted calibration and the %s one" % (name, label))

    # Progress: each generation's simulations, accepted particles and ETA, as lines
    # (TALUS_PROGRESS_INTERVAL=0: one per simulation).
    r = tool("calibrate", *common, "--set", "particles=4", "--set", "generations=1", "--set", "realizations=4",
             "-o", os.path.join(work, "progress"), "--threads", "1",
             env=dict(os.environ, TALUS_PROGRESS_INTERVAL="0"))
    lines = [l for l in r.stderr.splitlines() if " ETA " in l]
    if not (any(l.startswith("calibrate: generation 0 (prior): 2 of 4 simulations, elapsed ") for l in lines) and
            any(l.startswith("calibrate: generation 1: ") and " particles accepted, elapsed " in l and
                l.endswith(" s (this batch)") for l in lines)):
        failures.append("no progress lines per generation: %s" % r.stderr.strip()[-600:])

    # A budget that runs out during generation 1 leaves only the prior's sample: an error,
    # no posterior, and a checkpoint that --predict refuses (docs/calibration.md, Method).
    budget = os.path.join(work, "budget")
    particles = int(next(kv for kv in size if kv.startswith("particles=")).split("=")[1])
    r = tool("calibrate", *common, "--set", "max_simulations=%d" % (2 * particles), "-o", budget, "--threads", "2",
             "-q", expect=1)
    if not r.stderr.startswith("calibrate: error: the simulation budget (max_simulations %d) ran out during "
                               "generation 1" % (2 * particles)) or "there is no posterior" not in r.stderr:
        failures.append("a budget spent in generation 1 is not reported as such: %s" % r.stderr.strip())
    if r.stdout or any(os.path.exists(os.path.join(budget, n)) for n in ("posterior.csv", "summary.csv")):
        failures.append("a budget spent in generation 1 still gave a posterior: %s" % sorted(os.listdir(budget)))

    # No block comes to rest within 10 steps: every distance is infinite, and calibrate stops
    # after generation 0 saying so (it looped forever on a tolerance of NaN).
    stuck = os.path.join(work, "stuck")
    r = tool("calibrate", *common, "--set", "set=[terrain=%s, block_file=%s, engine.max_steps=10]" % (terrain, blocks),
             "-o", stuck, "-q", expect=1)
    if "generation 0: %s of its %s simulations had fewer than 2 realizations at rest" % (particles, particles) \
            not in r.stderr:
        failures.append("a calibration whose simulations cannot be compared is not reported as such: %s"
                        % r.stderr.strip())

    with open(os.path.join(fit, "summary.csv")) as f:
        rows = {r["parameter"]: r for r in csv.DictReader(f)}
    statistical = not args.sanitized
    for name, true in TRUTH.items():
        r = rows[name]
        p5, p50, p95 = float(r["P5"]), float(r["P50"]), float(r["P95"])
        print("%s: truth %g, posterior P5 %.4g, P50 %.4g, P95 %.4g" % (name, true, p5, p50, p95))
        if statistical and not p5 <= true <= p95:
            failures.append("%s: the truth %g is outside the posterior's [P5, P95] = [%.4g, %.4g]" % (name, true, p5, p95))
    friction = rows["ground.friction_angle_mean_deg"]
    prior_sd = (float(friction["max"]) - float(friction["min"])) / 12 ** 0.5
    if statistical and not float(friction["sd"]) < prior_sd:
        failures.append("the friction angle's posterior sd %s is not below the prior's %.4g" % (friction["sd"], prior_sd))
    with open(os.path.join(fit, "generations.csv")) as f:
        tolerances = [float(r["tolerance"]) for r in csv.DictReader(f)][1:]
    if statistical and not all(b < a for a, b in zip(tolerances, tolerances[1:])):
        failures.append("the tolerance did not fall at every generation: %s" % tolerances)

    # Stops compared by their horizontal distance from the drop point alone (variables:
    # distance, as field data measured from the drop point are): the truth recovered too.
    if statistical:
        by_distance = os.path.join(work, "distance")
        tool("calibrate", *common, "--set", "variables=distance", "-o", by_distance, "--threads", "2", "-q")
        with open(os.path.join(by_distance, "summary.csv")) as f:
            drows = {r["parameter"]: r for r in csv.DictReader(f)}
        for name, true in TRUTH.items():
            p5, p95 = float(drows[name]["P5"]), float(drows[name]["P95"])
            print("%s, by distance: posterior P5 %.4g, P95 %.4g" % (name, p5, p95))
            if not p5 <= true <= p95:
                failures.append("%s (variables: distance): the truth %g is outside [P5, P95] = [%.4g, %.4g]"
                                % (name, true, p5, p95))

    predict = os.path.join(work, "predict")
    draws = ["predictive_draws=3", "realizations=8"] if args.sanitized else \
            ["predictive_draws=16", "realizations=20"] if args.quick else ["predictive_draws=16", "realizations=30"]
    pargs = ["-c", os.path.join(SAMPLE, "predict.yaml"), "--set", "set=[terrain=%s, block_file=%s]" % (terrain, blocks),
             "--set", "groups[0].observed=" + obs_b, "--set", "plots=false"]
    for kv in draws:
        pargs += ["--set", kv]
    tool("calibrate", *pargs, "--predict", os.path.join(fit, "posterior.h5"), "-o", predict, "-q")
    r = tool("calibrate", *pargs, "--predict", os.path.join(budget, "posterior.h5"), "-o", predict + "-prior", "-q",
             expect=3)
    if "holds generation 0 only (the prior's sample)" not in r.stderr:
        failures.append("--predict took the prior's sample for a posterior: %s" % r.stderr.strip())
    # The checkpoint of the calibration killed after generation 1 is a stage of the fit.
    r = tool("calibrate", *pargs, "--predict", interrupted, "-o", predict + "-interrupted", "-q", expect=3)
    if "is the checkpoint of a calibration that did not finish (its last complete generation is 1)" not in r.stderr:
        failures.append("--predict took an unfinished calibration's checkpoint for a posterior: %s" % r.stderr.strip())
    with open(os.path.join(predict, "predictive.csv")) as f:
        runout = [r for r in csv.DictReader(f) if r["variable"] == "runout"]
    inside = sum(int(r["inside"]) for r in runout)
    print("drop B: %d of %d observed runout quantiles inside the predictive band" % (inside, len(runout)))
    if statistical and inside < len(runout) - 1:
        failures.append("drop B: only %d of %d observed runout quantiles inside the predictive band" % (inside, len(runout)))
    with open(os.path.join(predict, "predictive-ks.csv")) as f:
        ks = {r["variable"]: r for r in csv.DictReader(f)}
    print("drop B: runout KS %s (p %s)" % (ks["runout"]["ks_distance"], ks["runout"]["ks_p_value"]))
    if statistical and float(ks["runout"]["ks_p_value"]) < 0.01:
        failures.append("drop B: the predictive runout is refused by KS (p = %s)" % ks["runout"]["ks_p_value"])

    if not args.keep:
        shutil.rmtree(work, ignore_errors=True)
    for f in failures:
        print("FAILED: " + f)
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
