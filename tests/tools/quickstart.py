#!/usr/bin/python3
"""The quick start of README.md ("A study of your own") keeps its blocks on the DEM.

samples/quickstart is copied to a scratch folder and its four commands are run as the
README gives them, with the scene's full realization count. Checked:

- every tool exits 0 and stats gives no warning (no censoring above 10 %);
- at most 5 % of the realizations left the DEM or were cut by the step limit
  (summary.csv: end:left_terrain, end:step_limit) and none failed numerically;
- the run-out zone holds at least 90 % of the blocks (stop:run-out), and the fence
  line is crossed (cross:fence > 0).

Usage: quickstart.py --bin BUILD/bin [--realizations N] [--keep DIR]
--realizations: fewer realizations (sanitizer builds); the share checks then allow
one realization more. Exit 0 on success, 1 on a failed check. Standard library only.
"""
import argparse
import csv
import os
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SAMPLE = os.path.join(ROOT, "samples", "quickstart")


def run(cmd, cwd):
    p = subprocess.run(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if p.returncode != 0:
        sys.exit("quickstart: %s exited %d: %s" % (" ".join(cmd), p.returncode, p.stderr.strip()[-400:]))
    return p.stderr


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", required=True)
    ap.add_argument("--realizations", type=int, default=0)
    ap.add_argument("--keep")
    a = ap.parse_args()
    b = os.path.abspath(a.bin)
    work = a.keep or tempfile.mkdtemp(prefix="talus_quickstart_")
    if a.keep:
        shutil.rmtree(work, ignore_errors=True)
    try:
        shutil.copytree(SAMPLE, work, dirs_exist_ok=True)
        scene = ["--set", "realizations=%d" % a.realizations] if a.realizations else []
        run([os.path.join(b, "terrain-gen"), "dem.asc", "-c", "my-terrain.yaml", "-o", "terrain.h5"], work)
        run([os.path.join(b, "block-gen"), "rock-scan.ply", "-o", "rock.h5"], work)
        run([os.path.join(b, "dda-run"), "-c", "my-scene.yaml", "--set", "terrain=terrain.h5", "--set",
             "block_file=rock.h5", "-o", "run.h5"] + scene, work)
        err = run([os.path.join(b, "stats"), "run.h5", "-o", "stats/", "--set", "bootstrap_resamples=0",
                   "--set", "plots=false"], work)
        failures = []
        if "warning" in err:
            failures.append("stats warned: " + err.strip())
        fraction, count = {}, {}
        with open(os.path.join(work, "stats", "summary.csv"), newline="") as f:
            for row in csv.DictReader(f):
                if row["block"] != "all":
                    continue
                if row["statistic"] == "fraction":
                    fraction[row["variable"]] = float(row["value"])
                if row["variable"] == "realizations":
                    count["n"] = float(row["value"])
        slack = 1.0 / count["n"] if a.realizations else 0.0
        off = fraction.get("end:left_terrain", 0.0) + fraction.get("end:step_limit", 0.0)
        if off > 0.05 + slack:
            failures.append("%.1f %% of the realizations left the DEM or reached the step limit (at most 5 %%)" %
                            (100 * off))
        if fraction.get("numerical_failure", 0.0) > 0.0:
            failures.append("numerical failures: %g" % fraction["numerical_failure"])
        if fraction.get("stop:run-out", 0.0) < 0.9 - slack:
            failures.append("stop:run-out is %g (at least 0.9)" % fraction.get("stop:run-out", 0.0))
        if fraction.get("cross:fence", 0.0) <= 0.0:
            failures.append("no block crossed the fence")
        for f in failures:
            print("quickstart: " + f, file=sys.stderr)
        print("quickstart: %d realizations, %.1f %% off the DEM, %.1f %% in the run-out, %.1f %% across the fence" %
              (count["n"], 100 * off, 100 * fraction.get("stop:run-out", 0.0), 100 * fraction.get("cross:fence", 0.0)))
        return 1 if failures else 0
    finally:
        if not a.keep:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
