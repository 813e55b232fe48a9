#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""dda-run under make, Slurm and a terminal (docs/errors.md), end to end:

  - --resume without a journal is a fresh run (a Makefile rule can always pass it);
  - a second writer on the same output is refused while the first runs (lock);
  - SIGINT and SIGTERM end with 130/143, keep the finished realizations in a resumable
    journal, and the resume gives the uninterrupted run's records; so does a signal
    the moment the handlers are in place, before the first realization;
  - temporaries of dead processes of this host are removed, other hosts' are kept;
  - the default thread count follows the affinity mask and SLURM_CPUS_PER_TASK;
  - progress lines (not a terminal) name the output and shard; the summary line;
  - on a terminal, one refreshing line for a lone process, whole labelled lines for
    shards and for jobs of a parallel make (two shards under make -j2);
  - a build without MPI refuses to run under an MPI launcher; --version says so;
  - a stats output folder keeps only this run's outputs;
  - talus-plot --help works without plotting libraries, honours TALUS_PYTHON.

Usage: run_control.py --bin BUILD/bin [--realizations N]
"""
import argparse
import os
import pty
import select
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time

PLANE = "source: synthetic\nsynthetic: {kind: plane, cell_size: 1, width: 10, length: 20, slope_angle_deg: 35}\n"
BLOCKS = "blocks: [{name: c, solid: cube, volume: 0.5}]\n"
SCENE = """terrain: t.h5
block_file: b.h5
release: {{points: [[3.0, 5.0]], height: 1.0}}
realizations: {n}
seed: 3
outputs: {{chunk: 4, hazard_cell_size: 2}}
"""

failures = []


def run_on_tty(cmd, cwd, env):
    """Runs cmd with its standard output and error on a new pseudo-terminal; returns the
    exit code and everything written to the terminal."""
    master, slave = pty.openpty()
    p = subprocess.Popen(cmd, cwd=cwd, env=env, stdin=subprocess.DEVNULL, stdout=slave, stderr=slave)
    os.close(slave)
    out = b""
    while True:
        ready, _, _ = select.select([master], [], [], 1.0)
        if ready:
            try:
                data = os.read(master, 65536)
            except OSError:  # the terminal is closed once every writer has ended
                data = b""
            if not data:
                break
            out += data
        elif p.poll() is not None:
            break
    os.close(master)
    return p.wait(), out.decode(errors="replace")


def check(condition, what, detail=""):
    if not condition:
        failures.append(what + (": " + detail.strip() if detail else ""))
        print("FAIL " + what + (": " + detail.strip() if detail else ""))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--bin", required=True)
    parser.add_argument("--realizations", type=int, default=300,
                        help="realizations of the runs that are interrupted (fewer for slow sanitized builds)")
    args = parser.parse_args()
    b = os.path.abspath(args.bin)
    dda = os.path.join(b, "dda-run")
    work = tempfile.mkdtemp(prefix="talus-run-control-")

    def run(cmd, env=None, **kw):
        e = dict(os.environ)
        e.pop("SLURM_CPUS_PER_TASK", None)
        e.update(env or {})
        return subprocess.run(cmd, cwd=work, capture_output=True, text=True, env=e, **kw)

    try:
        for name, text in (("plane.yaml", PLANE), ("blocks.yaml", BLOCKS), ("scene.yaml", SCENE.format(n=args.realizations))):
            with open(os.path.join(work, name), "w") as f:
                f.write(text)
        assert run([os.path.join(b, "terrain-gen"), "-c", "plane.yaml", "-o", "t.h5"]).returncode == 0
        assert run([os.path.join(b, "block-gen"), "-c", "blocks.yaml", "-o", "b.h5"]).returncode == 0

        # --resume with nothing to resume: a fresh run, with the summary line.
        r = run([dda, "-c", "scene.yaml", "--set", "realizations=20", "--threads", "1", "--resume", "-o", "small.h5"])
        check(r.returncode == 0 and os.path.exists(os.path.join(work, "small.h5")), "--resume without a journal runs",
              r.stderr)
        check("small.h5: 20 realizations in " in r.stderr and "; ends: " in r.stderr, "end-of-run summary", r.stderr)
        check(not any(n.startswith("small.h5.") for n in os.listdir(work)), "no journal or lock left after a run")

        # A stats folder holds only this run's outputs: a stale hazard map is removed, and said.
        st = [os.path.join(b, "stats"), "small.h5", "-o", "st", "--set", "plots=false"]
        r = run(st)
        check(r.returncode == 0 and os.path.isdir(os.path.join(work, "st", "hazard")), "stats writes hazard maps",
              r.stderr)
        stale = os.path.join(work, "st", "hazard", "gone-reach_probability.asc")
        with open(stale, "w") as f:
            f.write("old")
        r = run(st)
        check(r.returncode == 0 and not os.path.exists(stale) and "gone-reach_probability.asc" in r.stderr,
              "stats removes and names a stale output", r.stderr)
        r = run(st)
        # The scene's blocks all leave the small terrain: the one line stats prints is the
        # censored-share warning (docs/stats.md), nothing else.
        check(r.returncode == 0 and r.stderr.count("\n") == 1 and
              r.stderr.startswith("stats: warning: small: 100 % of the realizations (20 of 20) did not stop"),
              "stats rerun removes nothing of its own", r.stderr)

        # The reference for the interrupted runs. They must still be running when the
        # signal comes (a journal, 0.3 s, a refused second writer): with fewer
        # realizations than take 2 s on this machine and build, the scene gets more.
        n = args.realizations
        while True:
            started = time.time()
            r = run([dda, "-c", "scene.yaml", "--threads", "1", "-q", "-o", "ref.h5"])
            took = time.time() - started
            if r.returncode != 0 or took >= 2.0 or n >= 100000:
                break
            n = int(n * min(20.0, 2.5 / max(took, 0.01))) + 1
            with open(os.path.join(work, "scene.yaml"), "w") as f:
                f.write(SCENE.format(n=n))
        check(r.returncode == 0, "reference run", r.stderr)

        for sig, code in ((signal.SIGINT, 130), (signal.SIGTERM, 143)):
            out = f"int{code}.h5"
            first = subprocess.Popen([dda, "-c", "scene.yaml", "--threads", "1", "-o", out], cwd=work,
                                     stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            deadline = time.time() + 30
            while not os.path.isdir(os.path.join(work, out + ".journal")) and time.time() < deadline:
                time.sleep(0.05)
            time.sleep(0.3)
            second = run([dda, "-c", "scene.yaml", "--threads", "1", "--resume", "-o", out])
            check(second.returncode == 1 and "another process (pid %d" % first.pid in second.stderr
                  and out + ".lock" in second.stderr, "a second writer is refused while the first runs", second.stderr)
            first.send_signal(sig)
            _, err = first.communicate(timeout=60)
            check(first.returncode == code, f"signal {sig.name} ends with {code}", f"{first.returncode}: {err}")
            check("realizations are in the journal " + out + ".journal" in err and "--resume" in err,
                  f"signal {sig.name} says how to resume", err)
            check(os.path.isdir(os.path.join(work, out + ".journal")) and not os.path.exists(os.path.join(work, out)),
                  f"signal {sig.name} leaves the journal and no output")
            r = run([dda, "-c", "scene.yaml", "--threads", "1", "--resume", "-v", "-o", out])
            check(r.returncode == 0 and "already done" in r.stderr, f"resume after {sig.name}", r.stderr)
            if shutil.which("h5diff"):
                for g in ("/records", "/hazard", "/crossings"):
                    d = run(["h5diff", "ref.h5", out, g, g])
                    check(d.returncode == 0, f"resume after {sig.name} equals the uninterrupted run in {g}", d.stdout)

        # A signal as early as the handler can see it (the moment /proc says it is caught,
        # while the scene is still being read): the same line and exit code, never the
        # default action, and a journal (or none) that --resume completes.
        for sig, code in ((signal.SIGINT, 130), (signal.SIGTERM, 143)):
            out = f"early{code}.h5"
            first = subprocess.Popen([dda, "-c", "scene.yaml", "--threads", "1", "-o", out], cwd=work,
                                     stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                                     restore_signals=True)
            deadline = time.time() + 30
            caught = False
            while not caught and first.poll() is None and time.time() < deadline:
                try:
                    with open(f"/proc/{first.pid}/status") as f:
                        mask = next(int(l.split()[1], 16) for l in f if l.startswith("SigCgt:"))
                    caught = bool(mask & (1 << (int(sig) - 1)))
                except (OSError, StopIteration):
                    pass
                if not caught:
                    time.sleep(0.0005)
            first.send_signal(sig)
            _, err = first.communicate(timeout=60)
            check(first.returncode == code and err.count("dda-run: error:") == 1 and "--resume" in err,
                  f"an early {sig.name} ends with {code} and one line", f"{first.returncode}: {err}")
            r = run([dda, "-c", "scene.yaml", "--threads", "1", "--resume", "-o", out])
            check(r.returncode == 0, f"resume after an early {sig.name}", r.stderr)

        # A signal does not wait for the realizations in hand: one long realization (a block
        # floating without gravity for 600 s in steps of 10 µs, every step searched) is
        # abandoned within a few hundred steps, and the run ends at once, with nothing of it
        # in the journal.
        out = "long.h5"
        long_run = [dda, "-c", "scene.yaml", "--set", "realizations=1", "--set", "engine.time_step=1e-5",
                    "--set", "engine.min_time_step=1e-7", "--set", "engine.flight_test=false", "--set",
                    "engine.gravity=0", "--set", "engine.max_time=600", "--threads", "1", "-o", out]
        first = subprocess.Popen(long_run, cwd=work, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        deadline = time.time() + 30
        while not os.path.isdir(os.path.join(work, out + ".journal")) and time.time() < deadline:
            time.sleep(0.05)
        time.sleep(1.0)
        signalled = time.time()
        first.send_signal(signal.SIGINT)
        _, err = first.communicate(timeout=60)
        waited = time.time() - signalled
        check(first.returncode == 130 and "0 of 1 realizations are in the journal" in err,
              "SIGINT abandons the realization in hand", f"{first.returncode}: {err}")
        check(waited < 5.0, "SIGINT ends a long realization within seconds", f"{waited:.1f} s")

        # Leftover temporaries: this host's dead process is removed, another host's kept.
        host = socket.gethostname().replace("-", "_").replace("/", "_")
        dead = f".tmp.h5.tmp-{host}-999999999"
        other = ".tmp.h5.tmp-otherhost-1"
        for n in (dead, other):
            with open(os.path.join(work, n), "w") as f:
                f.write("half")
        r = run([dda, "-c", "scene.yaml", "--set", "realizations=4", "--threads", "1", "-o", "tmp.h5"])
        check(r.returncode == 0 and not os.path.exists(os.path.join(work, dead)), "stale temporary removed", r.stderr)
        check(os.path.exists(os.path.join(work, other)), "another host's temporary kept")

        # Threads: affinity mask and Slurm.
        small = [dda, "-c", "scene.yaml", "--set", "realizations=4", "-o", "thr.h5"]
        if shutil.which("taskset"):
            r = run(["taskset", "-c", "0"] + small)
            check("1 thread (affinity mask)" in r.stderr, "taskset -c 0 gives one thread", r.stderr)
        r = run(small, env={"SLURM_CPUS_PER_TASK": "3"})
        check("3 threads (SLURM_CPUS_PER_TASK)" in r.stderr, "SLURM_CPUS_PER_TASK sets the threads", r.stderr)

        # Progress lines in a log, labelled with output and shard.
        r = run([dda, "-c", "scene.yaml", "--set", "realizations=20", "--threads", "1", "--shard", "1/2",
                 "-o", "part.h5"], env={"TALUS_PROGRESS_INTERVAL": "0"})
        lines = [l for l in r.stderr.splitlines() if "ETA" in l]
        check(len(lines) >= 5 and all(l.startswith("dda-run: part.h5 [shard 1/2]: ") for l in lines),
              "progress lines name output and shard", r.stderr)
        # Progress on a terminal: one refreshing line for a lone process; whole lines,
        # labelled, for processes that share it (shards, jobs of a parallel make).
        tty_env = dict(os.environ, TALUS_PROGRESS_INTERVAL="0")
        tty_env.pop("MAKEFLAGS", None)
        tty_env.pop("SLURM_CPUS_PER_TASK", None)
        rc, out = run_on_tty([dda, "-c", "scene.yaml", "--set", "realizations=8", "--threads", "1", "-o", "tty.h5"],
                             work, tty_env)
        check(rc == 0 and "\rtty.h5: 8/8 realizations" in out, "a lone process refreshes one line on a terminal", out)
        rc, out = run_on_tty([dda, "-c", "scene.yaml", "--set", "realizations=16", "--threads", "1", "--shard", "1/2",
                              "-o", "tty-part.h5"], work, tty_env)
        lines = [l for l in out.replace("\r\n", "\n").split("\n") if "ETA" in l]
        check(rc == 0 and "\r" not in out.replace("\r\n", "\n") and len(lines) >= 4 and
              all(l.startswith("dda-run: tty-part.h5 [shard 1/2]: ") for l in lines),
              "a shard prints whole labelled lines on a terminal", out)
        rc, out = run_on_tty([dda, "-c", "scene.yaml", "--set", "realizations=8", "--threads", "1", "-o", "tty-make.h5"],
                             work, dict(tty_env, MAKEFLAGS=" -j2 --jobserver-auth=3,4"))
        check(rc == 0 and "\r" not in out.replace("\r\n", "\n") and "dda-run: tty-make.h5: 4/8 realizations" in out,
              "a job of a parallel make prints whole lines on a terminal", out)
        if shutil.which("make"):
            # The case of the issue: two shards under make -j2 on one terminal.
            with open(os.path.join(work, "Makefile"), "w") as f:
                f.write("all: s0.h5 s1.h5\ns%.h5:\n\t" + dda + " -c scene.yaml --set realizations=16 --threads 1"
                        " --shard $*/2 -o $@\n")
            rc, out = run_on_tty(["make", "-j2", "-s"], work, tty_env)
            text = out.replace("\r\n", "\n")
            lines = [l for l in text.split("\n") if "ETA" in l]
            check(rc == 0 and "\r" not in text and
                  any(l.startswith("dda-run: s0.h5 [shard 0/2]: ") for l in lines) and
                  any(l.startswith("dda-run: s1.h5 [shard 1/2]: ") for l in lines) and
                  all(l.startswith(("dda-run: s0.h5 [shard 0/2]: ", "dda-run: s1.h5 [shard 1/2]: ")) for l in lines),
                  "two shards under make -j2 print whole labelled lines on one terminal", out)
        r = run([dda, "-q", "-c", "scene.yaml", "--set", "realizations=4", "-o", "quiet.h5"],
                env={"TALUS_PROGRESS_INTERVAL": "0"})
        check(r.returncode == 0 and r.stderr == "", "-q prints nothing", r.stderr)

        # MPI.
        version = run([dda, "--version"]).stdout
        check("MPI: " in version and "GDAL" in version and "HDF5" in version, "--version lists the optional parts",
              version)
        if "MPI: no" in version:
            r = run(small, env={"OMPI_COMM_WORLD_SIZE": "2"})
            check(r.returncode == 2 and "built without MPI" in r.stderr, "no-MPI build refuses an MPI launcher",
                  r.stderr)

        # talus-plot (the figures of calibrate).
        plot = os.path.join(b, "talus-plot")
        r = run(["python3", plot, "--help"], env={"TALUS_PYTHON": ""})
        check(r.returncode == 0 and "--calibration" in r.stdout, "talus-plot --help", r.stderr)
        r = run(["python3", plot, "--calibration", "a.h5", "out"], env={"TALUS_PYTHON": "/nonexistent/python"})
        check(r.returncode == 1 and "TALUS_PYTHON=/nonexistent/python" in r.stderr, "talus-plot honours TALUS_PYTHON",
              r.stderr)
        r = run(["python3", plot, "a.h5"])
        check(r.returncode == 2 and len(r.stderr.splitlines()) == 1, "talus-plot usage error in one line", r.stderr)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print(f"{len(failures)} failed checks")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
