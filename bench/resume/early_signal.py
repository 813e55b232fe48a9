#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""How soon after its start dda-run handles SIGINT and SIGTERM (docs/errors.md).

Starts `dda-run` on a small scene TRIALS times for each delay, sends the signal DELAY
milliseconds after the exec (busy-waited), and counts how each process ended:

  handled   exit 130 (SIGINT) or 143 (SIGTERM) with one `dda-run: error:` line;
  killed    ended by the signal's default action (no message);
  other     anything else (a finished run, another exit code or message).

It also measures, over the same number of starts, the time from the exec to the moment
/proc shows the handlers installed (SigCgt): the window in which a signal still kills.

    early_signal.py --bin build/bin [--trials 20] [--delays 0,0.5,1,2,4,8,16]

Exit code 0 when every signal sent after the handlers were seen installed was handled
(a signal before that moment may kill: that is the window being measured).
"""
import argparse
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time

PLANE = """source: synthetic
synthetic: {kind: plane, cell_size: 1, width: 12, length: 30, slope_angle_deg: 35}
materials:
  - {name: ground, restitution_mean: 0.6, friction_angle_mean_deg: 30}
"""
BLOCKS = "blocks: [{name: c, solid: cube, volume: 0.5}]\n"
SCENE = """terrain: t.h5
block_file: b.h5
release: {points: [[3.0, 6.0]], height: 1.5}
realizations: 100000
"""


def busy_wait(until):
    while time.perf_counter() < until:
        pass


def handlers_installed(pid, sig):
    try:
        with open(f"/proc/{pid}/status") as f:
            mask = next(int(line.split()[1], 16) for line in f if line.startswith("SigCgt:"))
        return bool(mask & (1 << (int(sig) - 1)))
    except (OSError, StopIteration):
        return False


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--bin", required=True, help="directory of the built tools")
    parser.add_argument("--trials", type=int, default=20, help="starts per delay and signal")
    parser.add_argument("--delays", default="0,0.5,1,2,4,8,16", help="milliseconds after the exec, comma-separated")
    args = parser.parse_args()
    b = os.path.abspath(args.bin)
    dda = os.path.join(b, "dda-run")
    work = tempfile.mkdtemp(prefix="talus-early-signal-")
    for name, text in (("plane.yaml", PLANE), ("blocks.yaml", BLOCKS), ("scene.yaml", SCENE)):
        with open(os.path.join(work, name), "w") as f:
            f.write(text)
    for cmd in (["terrain-gen", "-c", "plane.yaml", "-o", "t.h5"], ["block-gen", "-c", "blocks.yaml", "-o", "b.h5"]):
        subprocess.run([os.path.join(b, cmd[0])] + cmd[1:], cwd=work, check=True, capture_output=True)

    # The window: exec to the handlers seen installed.
    window = []
    for _ in range(args.trials):
        p = subprocess.Popen([dda, "-c", "scene.yaml", "--threads", "1", "-o", "w.h5"], cwd=work,
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        start = time.perf_counter()
        while not handlers_installed(p.pid, signal.SIGINT) and p.poll() is None:
            pass
        window.append(1e3 * (time.perf_counter() - start))
        p.kill()
        p.wait()
    print(f"exec to handlers installed: median {statistics.median(window):.2f} ms, "
          f"min {min(window):.2f} ms, max {max(window):.2f} ms ({args.trials} starts)")

    failures = 0
    print("signal   delay (ms)  handled  killed  other")
    for sig, code in ((signal.SIGINT, 130), (signal.SIGTERM, 143)):
        for delay in (float(d) for d in args.delays.split(",")):
            counts = {"handled": 0, "killed": 0, "other": 0}
            for k in range(args.trials):
                out = f"s{k}.h5"
                p = subprocess.Popen([dda, "-c", "scene.yaml", "--threads", "1", "-o", out], cwd=work,
                                     stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
                busy_wait(time.perf_counter() + delay / 1e3)
                installed = handlers_installed(p.pid, sig)
                p.send_signal(sig)
                _, err = p.communicate(timeout=120)
                if p.returncode == code and err.count("dda-run: error:") == 1 and err.count("\n") == 1:
                    counts["handled"] += 1
                elif p.returncode == -int(sig):
                    counts["killed"] += 1
                    failures += installed
                else:
                    counts["other"] += 1
                    failures += 1
                    print(f"  {sig.name} at {delay} ms: exit {p.returncode}: {err.strip()}")
                for leftover in (out + ".journal", out + ".lock", out):
                    path = os.path.join(work, leftover)
                    if os.path.isdir(path):
                        subprocess.run(["rm", "-r", path])
                    elif os.path.exists(path):
                        os.remove(path)
            print(f"{sig.name:8} {delay:10.2f}  {counts['handled']:7}  {counts['killed']:6}  {counts['other']:5}")
    subprocess.run(["rm", "-r", work])
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
