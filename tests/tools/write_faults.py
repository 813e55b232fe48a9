#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Write-failure injection for every tool (docs/errors.md, "A full disk or a file-size limit").

Each case runs one tool once to completion (its good outputs), then again for k over a
spread of file-size limits (RLIMIT_FSIZE, as `ulimit -f`, in bytes) from 0 to past its
largest file, so that a write fails with EFBIG in every file it writes, early and late.
Each failing run must:

  - exit 1 with exactly one line on standard error, "TOOL: error: ...";
  - leave every output at its final name byte-identical to the good one written before
    (an output never becomes a half-written file), and no temporary (".NAME.tmp-...");
  - for dda-run, leave a journal that `--resume` completes to the same records.

A run that does not hit the limit must exit 0 with the good outputs. When the process may
create a user namespace (`unshare -rm`), a last case per tool writes into a 16 KiB tmpfs,
where the writes fail with ENOSPC instead.

Usage: write_faults.py --bin BUILD/bin [--limits N] [--keep DIR] [-k TOOL]
"""
import argparse
import hashlib
import os
import resource
import shutil
import subprocess
import sys
import tempfile

PLANE_YAML = """source: synthetic
synthetic:
  kind: plane
  cell_size: 1
  width: 10
  length: 20
  slope_angle_deg: 35
materials:
  - name: rock
    restitution_mean: 0.8
"""

BLOCKS_YAML = """blocks:
  - name: c
    solid: cube
    volume: 0.5
xdmf: true
"""

SCENE_YAML = """terrain: t.h5
block_file: b.h5
release:
  points: [[3.0, 5.0]]
  height: 1.0
engine:
  max_steps: 3000
realizations: 6
seed: 3
outputs:
  chunk: 2
  hazard_cell_size: 2
"""

# A gentle plane where the blocks come to rest, for calibrate.
GENTLE_SCENE_YAML = """terrain: gentle.h5
block_file: b.h5
release:
  points: [[3.0, 5.0]]
  height: 1.0
engine:
  max_steps: 20000
realizations: 4
seed: 3
outputs:
  hazard_cell_size: 2
"""

CALIBRATE_YAML = """scene: gentle.yaml
groups:
  - observed: stops.csv
parameters:
  - {material: rock, parameter: restitution_mean, min: 0.1, max: 0.4}
realizations: 4
particles: 4
generations: 1
plots: false
"""

# (name, command, output under out/: a file or a directory, whether it is dda-run's run file)
CASES = [
    ("terrain-gen", ["terrain-gen", "-c", "plane.yaml", "-o", "out/t.h5"], True, False),
    ("block-gen", ["block-gen", "-c", "blocks.yaml", "-o", "out/b.h5"], True, False),
    ("dda-run", ["dda-run", "-c", "scene.yaml", "--threads", "1", "-o", "out/run.h5"], True, True),
    ("dda-run merge", ["dda-run", "merge", "s0.h5", "s1.h5", "-o", "out/m.h5"], True, False),
    ("stats", ["stats", "run.h5", "--set", "plots=true", "-o", "out/st"], False, False),
    ("calibrate", ["calibrate", "-c", "calibrate.yaml", "-o", "out/fit"], False, False),
]


def write(path, text):
    with open(path, "w") as f:
        f.write(text)


def digest_tree(root):
    """{relative path: sha256} of every file under root (journals excluded)."""
    found = {}
    for base, dirs, files in os.walk(root):
        dirs[:] = [d for d in dirs if not d.endswith(".journal")]
        for name in files:
            path = os.path.join(base, name)
            with open(path, "rb") as f:
                found[os.path.relpath(path, root)] = hashlib.sha256(f.read()).hexdigest()
    return found


def largest_file(root):
    size = 0
    for base, _, files in os.walk(root):
        for name in files:
            size = max(size, os.path.getsize(os.path.join(base, name)))
    return size


def temporaries(root):
    return [os.path.join(b, n) for b, _, files in os.walk(root) for n in files if ".tmp-" in n]


def run(bin_dir, cwd, command, limit=None, prefix=()):
    def set_limit():
        if limit is not None:
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit, resource.RLIM_INFINITY))

    exe = [os.path.join(bin_dir, command[0])] + command[1:]
    return subprocess.run(list(prefix) + exe, cwd=cwd, capture_output=True, text=True, preexec_fn=set_limit,
                          timeout=300)


def limits_for(size, count):
    """count limits in bytes, from 0 to just past `size`, denser at the start (headers)."""
    values = {0, 1, 100, 1000, 4096}
    for k in range(1, count + 1):
        values.add(int(size * (k / count) ** 2))
    return sorted(v for v in values if v <= size)[:max(count, 5) + 5] + [size + 1]


def can_mount_tmpfs():
    if not shutil.which("unshare"):
        return False
    r = subprocess.run(["unshare", "-rm", "sh", "-c", "d=$(mktemp -d) && mount -t tmpfs -o size=16k tmpfs $d"],
                       capture_output=True)
    return r.returncode == 0


class Checker:
    def __init__(self):
        self.failures = []

    def fail(self, case, k, what, r=None):
        tail = f"\n    stderr: {r.stderr.strip()[-400:]!r}" if r is not None else ""
        self.failures.append(f"{case} (limit {k}): {what}{tail}")


def check_failed_run(checker, name, k, r, out_dir, good, tool):
    lines = r.stderr.splitlines()
    if r.returncode != 1:
        checker.fail(name, k, f"exit code {r.returncode}, expected 1", r)
    if len(lines) != 1 or not lines[0].startswith(tool + ": error: "):
        checker.fail(name, k, "not one line '" + tool + ": error: ...' on standard error", r)
    left = temporaries(out_dir)
    if left:
        checker.fail(name, k, f"temporaries left: {left}")
    now = digest_tree(out_dir)
    for path, sha in now.items():
        if path not in good or (good[path] is not None and good[path] != sha):
            checker.fail(name, k, f"{path} differs from the good output (half-written?)", r)


def same_outputs(now, good):
    """The same files, each identical where the good runs agree (None: not compared)."""
    return set(now) == set(good) and all(good[p] is None or good[p] == now[p] for p in now)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--bin", required=True, help="directory of the built tools")
    parser.add_argument("--limits", type=int, default=12, help="file-size limits per tool (default 12)")
    parser.add_argument("--keep", help="work in this directory and keep it")
    parser.add_argument("-k", dest="filter", default="", help="run only cases whose name contains this")
    args = parser.parse_args()
    bin_dir = os.path.abspath(args.bin)
    work = os.path.abspath(args.keep) if args.keep else tempfile.mkdtemp(prefix="talus-write-faults-")
    if args.keep:
        shutil.rmtree(work, ignore_errors=True)
        os.makedirs(work)
    checker = Checker()
    tmpfs = can_mount_tmpfs()
    try:
        for name, text in (("plane.yaml", PLANE_YAML), ("blocks.yaml", BLOCKS_YAML), ("scene.yaml", SCENE_YAML),
                           ("gentle.yaml", GENTLE_SCENE_YAML), ("calibrate.yaml", CALIBRATE_YAML)):
            write(os.path.join(work, name), text)
        write(os.path.join(work, "stops.csv"), "x,y\n3.1,5\n3,5.1\n2.9,4.9\n")
        for command in (["terrain-gen", "-c", "plane.yaml", "-o", "t.h5"],
                        ["terrain-gen", "-c", "plane.yaml", "--set", "synthetic.slope_angle_deg=5", "--set",
                         "synthetic.length=40", "--set", "materials[0].restitution_mean=0.3", "-o", "gentle.h5"],
                        ["block-gen", "-c", "blocks.yaml", "-o", "b.h5"],
                        ["dda-run", "-c", "scene.yaml", "--threads", "1", "-o", "run.h5"],
                        ["dda-run", "-c", "scene.yaml", "--threads", "1", "--shard", "0/2", "-o", "s0.h5"],
                        ["dda-run", "-c", "scene.yaml", "--threads", "1", "--shard", "1/2", "-o", "s1.h5"]):
            r = run(bin_dir, work, command)
            if r.returncode != 0:
                sys.exit(f"fixture failed: {' '.join(command)}: {r.stderr.strip()}")
        summary = []
        for name, command, is_file, resumable in CASES:
            if args.filter and args.filter not in name:
                continue
            tool = "dda-run merge" if command[1:2] == ["merge"] else command[0]
            out_dir = os.path.join(work, "out")
            shutil.rmtree(out_dir, ignore_errors=True)
            os.makedirs(out_dir)
            r = run(bin_dir, work, command)
            if r.returncode != 0:
                checker.fail(name, "none", "the run without a limit failed", r)
                continue
            good = digest_tree(out_dir)
            keep_good = os.path.join(work, "good")
            shutil.rmtree(keep_good, ignore_errors=True)
            shutil.copytree(out_dir, keep_good)
            if not is_file:
                # Files that differ between two good runs (a GeoPackage's timestamps) are
                # checked for their name only.
                shutil.rmtree(out_dir)
                os.makedirs(out_dir)
                run(bin_dir, work, command)
                again = digest_tree(out_dir)
                for path in good:
                    if again.get(path) != good[path]:
                        good[path] = None
            limits = limits_for(largest_file(out_dir), args.limits)
            for k in limits:
                if not is_file:
                    # A directory output: start empty (calibrate refuses an earlier posterior
                    # without --resume), so every file present afterwards is a finished one.
                    shutil.rmtree(out_dir)
                    os.makedirs(out_dir)
                r = run(bin_dir, work, command, limit=k)
                if r.returncode == 0:
                    if not same_outputs(digest_tree(out_dir), good):
                        checker.fail(name, k, "exit 0 but the outputs differ from the good ones", r)
                    continue
                check_failed_run(checker, name, k, r, out_dir, good, tool)
                if resumable:
                    resumed = run(bin_dir, work, command + ["--resume"])
                    if resumed.returncode != 0:
                        checker.fail(name, k, "--resume after the failure failed", resumed)
                    elif shutil.which("h5diff"):
                        d = subprocess.run(["h5diff", os.path.join(keep_good, "run.h5"), os.path.join(out_dir, "run.h5"),
                                            "/records", "/records"], capture_output=True, text=True)
                        if d.returncode != 0:
                            checker.fail(name, k, "the resumed run's records differ from the run without a limit")
                    # The resume wrote its own run file (its command line differs): the good
                    # one goes back for the next limit.
                    shutil.copy(os.path.join(keep_good, "run.h5"), os.path.join(out_dir, "run.h5"))
            tested = len(limits)
            if tmpfs:
                # ENOSPC: the same command with an empty output directory on a 16 KiB
                # tmpfs; what it holds afterwards is copied out before the mount goes.
                tested += 1
                shutil.rmtree(out_dir)
                os.makedirs(out_dir)
                held = os.path.join(work, "held")
                shutil.rmtree(held, ignore_errors=True)
                script = ('mount -t tmpfs -o size=16k tmpfs out && "$@"; rc=$?; '
                          'mkdir held && cp -rp out/. held/; exit $rc')
                exe = [os.path.join(bin_dir, command[0])] + command[1:]
                r = subprocess.run(["unshare", "-rm", "sh", "-c", script, "sh"] + exe, cwd=work, capture_output=True,
                                   text=True, timeout=300)
                if r.returncode == 0:
                    if not same_outputs(digest_tree(held), good):
                        checker.fail(name, "tmpfs", "exit 0 but the outputs differ from the good ones", r)
                else:
                    check_failed_run(checker, name, "16 KiB tmpfs", r, held, good, tool)
            summary.append(f"{name}: {tested} write failures injected")
        print("\n".join(summary))
        if checker.failures:
            print(f"{len(checker.failures)} failure(s):\n" + "\n".join(checker.failures))
            return 1
        print("write_faults: all cases passed")
        return 0
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
