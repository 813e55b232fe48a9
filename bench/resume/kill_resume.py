#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Kill-at-random resume test of dda-run (docs/errors.md, docs/dda-run.md).

For each chunk size, runs a small scene once uninterrupted (the reference), then TRIALS
times: starts `dda-run --resume`, kills it with SIGKILL (or, with --signal, SIGINT or
SIGTERM) at a random moment between its start and a little after the reference's wall
time, and runs the same command (always with --resume) again to completion. A trial
passes when the second run succeeds, its records, crossings, hazard accumulators and
trajectories equal the reference's (h5diff), and nothing is left beside the run file
and its sidecar (no journal, no lock, no temporary).

    kill_resume.py --bin build/bin [--trials 50] [--chunks 1,64] [--realizations N]

Exit code 0 when every trial passes; 77 when h5diff (hdf5-tools) is missing.
"""
import argparse
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time

PLANE = """source: synthetic
synthetic: {kind: plane, cell_size: 1, width: 12, length: 30, slope_angle_deg: 35}
materials:
  - {name: ground, restitution_mean: 0.6, friction_angle_mean_deg: 30}
roughness: {sigma: 0.05}
"""
BLOCKS = "blocks: [{name: c, solid: cube, volume: 0.5}, {name: o, solid: octahedron, volume: 0.5}]\n"
SCENE = """terrain: t.h5
block_file: b.h5
release: {{kind: line, points: [[3.0, 3.0], [3.0, 9.0]], height: 1.5}}
engine: {{trajectory_interval: 0.05}}
realizations: {n}
seed: 11
outputs:
  chunk: {chunk}
  hazard_cell_size: 2
  barriers: [{{name: mid, line: [[15, 0], [15, 12]]}}]
"""
GROUPS = ["/records", "/crossings", "/hazard", "/trajectories"]


def run(cmd, cwd, check=True, **kw):
    r = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, **kw)
    if check and r.returncode != 0:
        sys.exit(f"failed: {' '.join(cmd)}: {r.stderr.strip()}")
    return r


def same_run(a, b, cwd):
    for g in GROUPS:
        r = subprocess.run(["h5diff", a, b, g, g], cwd=cwd, capture_output=True, text=True)
        if r.returncode != 0:
            return f"{g} differs: {(r.stdout + r.stderr).strip()[:300]}"
    return ""


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--bin", required=True)
    parser.add_argument("--trials", type=int, default=50)
    parser.add_argument("--chunks", default="1,64")
    parser.add_argument("--realizations", type=int, default=0,
                        help="realizations per run (default: max(40, 3 x chunk), so a run spans several chunks)")
    parser.add_argument("--threads", default="2")
    parser.add_argument("--signal", choices=["KILL", "INT", "TERM"], default="KILL")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    if shutil.which("h5diff") is None:
        print("h5diff (hdf5-tools) not found: skipped")
        return 77
    bin_dir = os.path.abspath(args.bin)
    dda = os.path.join(bin_dir, "dda-run")
    rng = random.Random(args.seed)
    work = tempfile.mkdtemp(prefix="talus-kill-resume-")
    failures = 0
    try:
        with open(os.path.join(work, "plane.yaml"), "w") as f:
            f.write(PLANE)
        with open(os.path.join(work, "blocks.yaml"), "w") as f:
            f.write(BLOCKS)
        run([os.path.join(bin_dir, "terrain-gen"), "-c", "plane.yaml", "-o", "t.h5"], work)
        run([os.path.join(bin_dir, "block-gen"), "-c", "blocks.yaml", "-o", "b.h5"], work)
        for chunk in [int(c) for c in args.chunks.split(",")]:
            scene = f"scene{chunk}.yaml"
            n = args.realizations or max(40, 3 * chunk)
            with open(os.path.join(work, scene), "w") as f:
                f.write(SCENE.format(n=n, chunk=chunk))
            start = time.monotonic()
            run([dda, "-c", scene, "--threads", args.threads, "-q", "-o", f"ref{chunk}.h5"], work)
            wall = time.monotonic() - start
            passed = 0
            kills = 0
            for trial in range(args.trials):
                out = f"run{chunk}.h5"
                cmd = [dda, "-c", scene, "--threads", args.threads, "--resume", "-q", "-o", out]
                proc = subprocess.Popen(cmd, cwd=work, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
                time.sleep(rng.uniform(0.0, 1.1 * wall))
                if proc.poll() is None:
                    proc.send_signal(getattr(signal, "SIG" + args.signal))
                    kills += 1
                _, err = proc.communicate()
                # A second kill half-way through the resume, in one trial of four.
                if rng.random() < 0.25:
                    p2 = subprocess.Popen(cmd, cwd=work, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                    time.sleep(rng.uniform(0.0, 0.5 * wall))
                    if p2.poll() is None:
                        p2.kill()
                    p2.wait()
                r = subprocess.run(cmd, cwd=work, capture_output=True, text=True)
                problem = ""
                if r.returncode != 0:
                    problem = f"resume failed ({r.returncode}): {r.stderr.strip()}"
                else:
                    problem = same_run(f"ref{chunk}.h5", out, work)
                    left = sorted(name for name in os.listdir(work) if name.startswith(out) and name != out or
                                  name.startswith("." + out))
                    if not problem and left:
                        problem = "left behind: " + ", ".join(left)
                if problem:
                    failures += 1
                    print(f"FAIL chunk {chunk} trial {trial}: {problem}")
                else:
                    passed += 1
                for name in os.listdir(work):
                    if name.startswith(out) or name.startswith("." + out):
                        path = os.path.join(work, name)
                        shutil.rmtree(path) if os.path.isdir(path) else os.remove(path)
            print(f"chunk {chunk}: {passed} of {args.trials} resumes identical to the reference "
                  f"({kills} killed with SIG{args.signal} mid-run; reference {wall:.1f} s, "
                  f"{n} realizations)")
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
