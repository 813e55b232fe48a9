#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Runs every shell command written in README.md and docs/*.md (docs/cli.md, "Commands
in the documents").

Each fenced block of the documents declares its language; the ```sh blocks are
commands, run as written, in order, one bash per document, in a scratch copy of the
repository root: the source tree's folders are linked (samples/ and configs/ are copied,
so that nothing is ever written into the source), build/bin is the tools' folder, which
is also first on PATH, and there is no out/ or any other output of an earlier run.

A command passes when it exits 0, or the code its trailing comment states (`# exits 3`),
and the files it names with -o (and --export-mesh) exist afterwards, or, for a command
that must fail, do not. The test fails naming the document, the line and the command.

Three short lists below change what is run, each entry with its reason:
  EXCLUDED    commands that cannot run here (installing, building, hours of work);
  OVERRIDES   arguments appended to a command line, only to make long runs short;
  STARTS_FROM documents that go on from another's outputs, as their text says.
An entry that matches no command is an error, so the lists cannot go stale silently.

Usage: doc_commands.py --bin BUILD/bin [--source ROOT] [--realizations N]
                       [-k WORD] [--list] [--keep DIR]
"""
import argparse
import glob
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import time

# Commands that are not run, matched against the command's text (a regular expression
# searched in it). Keep this list short: each entry needs a reason a reader accepts.
EXCLUDED = [
    (r"^\./scripts/(reference|test)\.sh\b",
     "installs packages and builds the tree (reference.sh then runs the whole study, whose steps are "
     "dda-run.md's and stats.md's commands, run here; test.sh runs this test)"),
    (r"^\./scripts/install-deps\.sh\b", "installs Debian packages (root)"),
    (r"^(cmake|ctest)\b", "builds or tests the tree this test is part of"),
    (r"^scripts/study\.sh\b",
     "the whole reference study (3 x 1000 realizations and 68 figures, about 10 s on 2 cores); its steps are "
     "dda-run.md's and stats.md's commands, run here with fewer realizations"),
    (r"^bench/stress/stress\.sh\b",
     "the stress suite (minutes to hours); its CI subset is the dda_stress_quick test"),
    (r"bench/resume/kill_resume\.py\b",
     "50 kill-and-resume trials take minutes; the dda_run_kill_resume test runs the same script with 4"),
    (r"^bench/dda/threshold_sensitivity\.sh\b", "45 runs of 1000 realizations"),
    (r"^git clone https://github\.com/richefeu/AuthumeQuarryRockfalls_Data-in-Brief\b",
     "downloads the Authume field data (network; not part of Talus)"),
    (r"^bench/field/authume\.py --data authume\b",
     "needs the Authume field data; the field_authume_script test runs the script on a synthetic dataset"),
    (r"^bench/dda/compare_runs\.py compare\b", "compares with run files of an earlier revision (BEFORE-S1.h5)"),
    (r"^bench/dda/equality\.sh\b",
     "record equality of two builds: 170 runs with each (about 70 s on two cores), one of them another build"),
    (r"^make (-j2 )?-C samples/bench-slope( check)?\s*(#.*)?$",
     "the whole bench-slope study (about 35 s on two cores) and its check; the bench_slope_make test runs "
     "the check (the study at 16 realizations per level, outputs checked)"),
    (r"^make (-j2 )?-C samples/bench-slope (paper|sensitivity|shapes)\s*(#.*)?$",
     "the bench-slope study beside the published one, its model-choice sensitivity (66 runs of 1000 "
     "realizations) and its shape measures (12 runs, 6 with trajectories); the table script they drive is run "
     "here on dda-run.md's run files (samples/bench-slope/paper.py table)"),
    (r"^make -C samples/bench-slope (calibration|prediction)\b",
     "the one-cell calibrations of the reference study (1114 and 600 simulations of 250 realizations, 20 and "
     "12 min on two cores) and its prediction of twelve cells; the calibration_summaries_recovery test runs the "
     "same chain on the calibration example"),
    (r"^bench/pareto/pareto\.py\b", "run time against error: about 80 runs of 500 realizations (an hour on 2 cores)"),
    (r"^valgrind --tool=callgrind\b",
     "instruction counts: the run under valgrind takes minutes; the same run without it is the whole-run law's "
     "command in the same document"),
    (r"^callgrind_annotate\b", "reads the counts of the valgrind command before it"),
    (r"^sbatch\b", "needs a Slurm cluster; the page runs the same script task by task with bash"),
]

# Commands that need a part of the build that is optional: run when it is there.
OPTIONAL = [
    (r"\bbench_bullet_peer\b", "bench_bullet_peer", "the rigid-body peer is built only with libbullet-dev"),
]

# (document, regular expression matched against one line of a command, arguments appended
# to that line). {n} is --realizations. Only to shorten long runs: nothing else changes.
OVERRIDES = [
    ("README.md", r"dda-run -c my-scene\.yaml", "--set realizations={n}"),
    ("README.md", r"dda-run -c my-zones\.yaml", "--set realizations={n}"),
    ("docs/dda-run.md", r"^\s*dda-run -c ", "--set realizations={n}"),
    ("docs/benchmarks.md", r"dda-run -c samples/bench-slope/scene\.yaml", "--set realizations={n}"),
    ("docs/benchmarks.md", r"bench_bullet_peer ", "-n {n}"),
    # The level-of-detail benchmark (12 runs of 1000 realizations) at N realizations per run.
    ("docs/block.md", r"bench/dda/mesh_convergence\.py ", "--realizations {n}"),
    ("docs/dda.md", r"bench/dda/washboard\.py ", "--realizations {n} --levels 8 16"),
    # The 2001 x 2001 DEM of the speed measurements, cut to 31 x 101 points.
    ("docs/benchmarks.md", r"--set synthetic\.width=4000 -o big-S2\.h5",
     "--set 'synthetic.profile=[[0,30],[6,24],[8,24],[14,18],[16,18],[22,12],[24,12],[36,0],[60,0]]' "
     "--set synthetic.width=200"),
    # The 2000 x 2000 DEM of the terrain-file measurements, cut to 200 x 200 points.
    ("docs/benchmarks.md", r"bench/terrain/big_dem\.py ", "--size 200"),
    ("docs/terrain.md", r"bench/terrain/big_dem\.py ", "--size 200"),
    # The 100 820-triangle rock of the block measurements, cut to 5 120 triangles.
    ("docs/benchmarks.md", r"block-gen -c bench/block/scan\.yaml", "--set blocks[0].resolution=16"),
    # The calibration example (minutes) as a one-generation fit of 6 particles, and a
    # prediction of 3 draws, every simulation of N realizations; the observed drop tests
    # shortened like every run.
    ("docs/calibration.md", r"^dda-run -c samples/calibration/drop\.yaml", "--set realizations={n}"),
    # The tutorial's run, whole and as the four tasks of its Slurm array (the script passes
    # its arguments to dda-run), shortened alike so that the merge equals the whole run.
    ("docs/tutorial-site.md", r"^\s*dda-run -c ", "--set realizations={n}"),
    ("docs/tutorial-site.md", r"bash samples/site/run-array\.sbatch", "--set realizations={n}"),
    ("docs/calibration.md", r"^calibrate -c samples/calibration/calibrate\.yaml",
     "--set particles=6 --set generations=1 --set realizations={n}"),
    ("docs/calibration.md", r"^calibrate -c samples/calibration/predict\.yaml",
     "--set predictive_draws=3 --set realizations={n}"),
    # The fit to summaries: one generation of 6 particles (its maximum is of 60 blocks, so
    # the simulations keep their 60 realizations).
    ("docs/calibration.md", r"^calibrate -c samples/calibration/summaries\.yaml",
     "--set particles=6 --set generations=1"),
]

# Documents whose commands go on from another document's outputs, as their text says:
# the document's scratch root starts as a copy of the other's after its commands ran.
STARTS_FROM = {
    "docs/stats.md": "docs/dda-run.md",            # "After dda-run has written the three runs ..."
    "docs/reference-study.md": "docs/dda-run.md",  # the run files of ./scripts/reference.sh
    "docs/benchmarks.md": "docs/dda-run.md",       # the study's run files in out/reference/
}

RUN_LANGUAGES = {"sh", "bash", "shell"}
EXIT_MARK = re.compile(r"#.*\bexits (\d+)\b")


class Command:
    def __init__(self, doc, line, text):
        self.doc, self.line, self.text = doc, line, text
        self.expect = 0
        self.excluded = None     # reason
        self.optional = None     # (binary, reason)
        self.appended = []       # (line index in text, arguments)
        self.outputs = []

    @property
    def where(self):
        return f"{self.doc}:{self.line}"

    def first_line(self):
        return self.text.splitlines()[0]


def strip_comment(line):
    """The line without its trailing comment (a '#' that starts a word outside quotes)."""
    quote = None
    for i, c in enumerate(line):
        if quote:
            if c == quote:
                quote = None
            elif c == "\\" and quote == '"':
                continue
        elif c in "'\"":
            quote = c
        elif c == "#" and (i == 0 or line[i - 1] in " \t;"):
            return line[:i].rstrip()
    return line.rstrip()


def complete(text):
    """Whether bash reads `text` as whole commands (no open quote, loop or function)."""
    if text.rstrip().endswith("\\"):
        return False
    r = subprocess.run(["bash", "-n"], input=text + "\n", capture_output=True, text=True)
    return r.returncode == 0


def blocks(path, rel, problems):
    """The fenced blocks of a Markdown file: (language, first body line number, body lines)."""
    lines = open(path, encoding="utf-8").read().split("\n")
    out, i = [], 0
    while i < len(lines):
        m = re.match(r"^(\s*)```(.*)$", lines[i])
        if not m:
            i += 1
            continue
        indent, lang = len(m.group(1)), m.group(2).strip()
        start, body = i + 1, []
        i += 1
        while i < len(lines) and not re.match(r"^\s*```\s*$", lines[i]):
            body.append(lines[i][indent:] if lines[i][:indent].strip() == "" else lines[i])
            i += 1
        if i == len(lines):
            problems.append(f"{rel}:{start}: fenced block is not closed")
        if not lang:
            problems.append(f"{rel}:{start}: fenced block without a language: write ```sh for commands "
                            "(they are run by this test), ```text for output or a usage line")
        out.append((lang, start + 1, body))
        i += 1
    return out


def commands(path, rel, problems):
    found = []
    for lang, first, body in blocks(path, rel, problems):
        if lang not in RUN_LANGUAGES:
            continue
        pending, start = [], None
        for k, line in enumerate(body):
            if not pending and (not line.strip() or line.lstrip().startswith("#")):
                continue
            if re.search(r"<<[^<]", strip_comment(line)):
                problems.append(f"{rel}:{first + k}: here-documents are not supported in ```sh blocks")
            if not pending:
                start = first + k
            pending.append(line)
            if complete("\n".join(pending)):
                found.append(Command(rel, start, "\n".join(pending)))
                pending = []
        if pending:
            problems.append(f"{rel}:{start}: incomplete shell command: {pending[0]}")
    return found


def output_paths(line):
    """Paths a command line promises to write: -o/--output and --export-mesh arguments."""
    try:
        words = shlex.split(strip_comment(line).rstrip("\\"))
    except ValueError:
        return []
    paths = []
    for k, w in enumerate(words[:-1]):
        if w in ("-o", "--output", "--export-mesh"):
            paths.append((w, words[k + 1]))
    return [(opt, p) for opt, p in paths if "$" not in p and "*" not in p]


def plan(cmds, realizations, problems):
    used_excluded, used_optional, used_overrides = set(), set(), set()
    for c in cmds:
        m = EXIT_MARK.search(c.text.splitlines()[-1])
        if m:
            c.expect = int(m.group(1))
        for k, (pattern, reason) in enumerate(EXCLUDED):
            if re.search(pattern, c.text):
                c.excluded = reason
                used_excluded.add(k)
        for k, (pattern, binary, reason) in enumerate(OPTIONAL):
            if re.search(pattern, c.text):
                c.optional = (binary, reason)
                used_optional.add(k)
        for k, (doc, pattern, args) in enumerate(OVERRIDES):
            if doc != c.doc:
                continue
            lines = c.text.splitlines()
            for i, line in enumerate(lines):
                if re.search(pattern, line):
                    # After the command's last continuation line: a later --set wins.
                    while strip_comment(lines[i]).endswith("\\") and i + 1 < len(lines):
                        i += 1
                    c.appended.append((i, args.format(n=realizations)))
                    used_overrides.add(k)
        for line in c.text.splitlines():
            c.outputs += output_paths(line)
    return used_excluded, used_optional, used_overrides


def with_overrides(c):
    lines = c.text.splitlines()
    for i, args in c.appended:
        code = strip_comment(lines[i])
        cont = code.endswith("\\")
        lines[i] = (code[:-1].rstrip() if cont else code) + " " + args + (" \\" if cont else "")
    return "\n".join(lines)


def make_root(root, source, bindir):
    os.makedirs(root)
    for name in sorted(os.listdir(source)):
        if name.startswith(".") or name.startswith("build") or name == "out":
            continue
        src = os.path.join(source, name)
        if name in ("samples", "configs"):
            shutil.copytree(src, os.path.join(root, name))
        else:
            os.symlink(src, os.path.join(root, name))
    os.makedirs(os.path.join(root, "build"))
    os.symlink(bindir, os.path.join(root, "build", "bin"))


def script_for(cmds, logs):
    """One bash script running a document's commands in order; it records each command's
    exit status and stops at the first unexpected one."""
    s = ["exec </dev/null", f"__status={shlex.quote(os.path.join(logs, 'status'))}"]
    for k, c in enumerate(cmds):
        if c.excluded or c.skip:
            continue
        out, err = os.path.join(logs, f"{k}.out"), os.path.join(logs, f"{k}.err")
        pre = [f"[ -e {shlex.quote(p)} ] && echo {shlex.quote(p)}" for _, p in c.outputs]
        s.append(f"echo start {k} $EPOCHREALTIME >> \"$__status\"")
        if pre:
            s.append("{ " + "; ".join(pre) + "; } > " + shlex.quote(out + ".before") + " 2>/dev/null")
        s.append("{\n" + with_overrides(c) + "\n} > " + shlex.quote(out) + " 2> " + shlex.quote(err))
        s.append(f"__rc=$?; echo \"end {k} $__rc $EPOCHREALTIME $PWD\" >> \"$__status\"")
        s.append(f"[ $__rc -eq {c.expect} ] || exit 1")
    s.append("exit 0")
    return "\n".join(s) + "\n"


def check_outputs(c, cwd, before):
    missing = []
    for opt, p in c.outputs:
        path = os.path.join(cwd, p)
        if c.expect == 0:
            exists = os.path.exists(path)
            if not exists and opt == "--export-mesh":
                stem, ext = os.path.splitext(path)
                exists = bool(glob.glob(glob.escape(stem) + "_*" + ext))
            if not exists:
                missing.append(f"{opt} {p} was not written")
        elif os.path.exists(path) and p not in before:
            missing.append(f"{opt} {p} was written by a command that failed")
    return missing


def tail(path, n=6):
    try:
        lines = open(path, errors="replace").read().splitlines()
    except OSError:
        return ""
    return "\n".join("    " + l for l in lines[-n:])


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--bin", required=True, help="folder of the built tools")
    parser.add_argument("--source", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."),
                        help="repository root (default: this file's)")
    parser.add_argument("--realizations", type=int, default=16,
                        help="realizations of the runs OVERRIDES shortens (default 16)")
    parser.add_argument("-k", dest="only", default="", help="run only the documents whose path contains this")
    parser.add_argument("--list", action="store_true", help="list the commands and what would be done; run nothing")
    parser.add_argument("--keep", help="keep the scratch roots in this new folder")
    parser.add_argument("--timeout", type=float, default=1200, help="seconds per document")
    args = parser.parse_args()
    source = os.path.realpath(args.source)
    bindir = os.path.realpath(args.bin)

    problems = []
    docs = ["README.md"] + sorted(os.path.relpath(p, source) for p in glob.glob(os.path.join(source, "docs", "*.md")))
    cmds = {d: commands(os.path.join(source, d), d, problems) for d in docs}
    flat = [c for d in docs for c in cmds[d]]
    if not flat:
        problems.append(f"no ```sh commands found in README.md and docs/*.md under {source}")
    used_ex, used_opt, used_ov = plan(flat, args.realizations, problems)
    problems += [f"EXCLUDED entry matches no command: {EXCLUDED[k][0]}" for k in range(len(EXCLUDED)) if k not in used_ex]
    problems += [f"OPTIONAL entry matches no command: {OPTIONAL[k][0]}" for k in range(len(OPTIONAL)) if k not in used_opt]
    problems += [f"OVERRIDES entry matches no command: {OVERRIDES[k][0]} {OVERRIDES[k][1]}"
                 for k in range(len(OVERRIDES)) if k not in used_ov]
    for c in flat:
        c.skip = None
        if c.optional and not os.path.exists(os.path.join(bindir, c.optional[0])):
            c.skip = f"{c.optional[0]} not built ({c.optional[1]})"

    if args.list:
        for c in flat:
            state = ("excluded: " + c.excluded if c.excluded else "optional: " + c.optional[1] if c.optional else
                     f"exits {c.expect}")
            print(f"{c.where}: {c.first_line()}\n    {state}" + "".join(f"\n    appends: {a}" for _, a in c.appended))
        for p in problems:
            print("PROBLEM " + p)
        return 1 if problems else 0

    for p in problems:
        print("FAIL " + p)
    work = os.path.abspath(args.keep) if args.keep else tempfile.mkdtemp(prefix="talus-doc-commands-")
    if args.keep:
        os.makedirs(work)
    env = dict(os.environ)
    env["PATH"] = bindir + os.pathsep + env.get("PATH", "")
    env.pop("SLURM_CPUS_PER_TASK", None)
    env.pop("MAKEFLAGS", None)
    selected = [d for d in docs if args.only in d]
    order = []
    for d in selected:           # a document's starting point runs first
        if d in STARTS_FROM and STARTS_FROM[d] not in order:
            order.append(STARTS_FROM[d])
        if d not in order:
            order.append(d)
    failed, passed, excluded, skipped = [], 0, 0, 0
    roots = {}
    try:
        for d in order:
            root = os.path.join(work, re.sub(r"[^A-Za-z0-9]+", "-", d))
            if d in STARTS_FROM:
                if STARTS_FROM[d] not in roots:
                    failed.append(f"{d}: its starting point {STARTS_FROM[d]} did not run")
                    continue
                shutil.copytree(roots[STARTS_FROM[d]], root, symlinks=True)
            else:
                make_root(root, source, bindir)
            logs = os.path.join(work, "logs-" + os.path.basename(root))
            os.makedirs(logs)
            started = time.monotonic()
            try:
                r = subprocess.run(["bash", "-c", script_for(cmds[d], logs)], cwd=root, env=env,
                                   timeout=args.timeout, capture_output=True, text=True)
                timed_out = False
            except subprocess.TimeoutExpired:
                timed_out = True
            status = {}
            last_started, started_at = None, 0.0
            if os.path.exists(os.path.join(logs, "status")):
                for line in open(os.path.join(logs, "status")):
                    parts = line.split(" ", 4)
                    if parts[0] == "start":
                        last_started, started_at = int(parts[1]), float(parts[2])
                    else:
                        status[int(parts[1])] = (int(parts[2]), float(parts[3]) - started_at, parts[4].rstrip("\n"))
            ok_doc = True
            for k, c in enumerate(cmds[d]):
                if c.excluded:
                    excluded += 1
                    if d in selected:
                        print(f"excluded {c.where}: {c.first_line()}\n    ({c.excluded})")
                    continue
                if c.skip:
                    skipped += 1
                    print(f"skipped  {c.where}: {c.first_line()}\n    ({c.skip})")
                    continue
                if k not in status:
                    if timed_out and k == last_started:
                        failed.append(f"{c.where}: {c.first_line()}\n    still running after {args.timeout:.0f} s")
                    elif ok_doc:
                        failed.append(f"{c.where}: {c.first_line()}\n    not run: {r.stderr.strip()}")
                    ok_doc = False
                    continue
                rc, seconds, cwd = status[k]
                before = set(open(os.path.join(logs, f"{k}.out.before")).read().split("\n")) \
                    if os.path.exists(os.path.join(logs, f"{k}.out.before")) else set()
                problems_k = check_outputs(c, cwd, before)
                if rc != c.expect:
                    problems_k.insert(0, f"exit {rc}, expected {c.expect}")
                if problems_k:
                    ok_doc = False
                    failed.append(f"{c.where}: {c.first_line()}\n    " + "; ".join(problems_k) +
                                  "\n" + tail(os.path.join(logs, f"{k}.err")))
                elif d in selected:
                    passed += 1
                    print(f"ok       {c.where} ({seconds:.1f} s): {c.first_line()}")
            if ok_doc:
                roots[d] = root
            print(f"-- {d}: {time.monotonic() - started:.1f} s")
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)
    for f in failed:
        print("FAIL " + f)
    print(f"{passed} passed, {len(failed) + len(problems)} failed, {excluded + skipped} skipped")
    return 1 if failed or problems else 0


if __name__ == "__main__":
    sys.exit(main())
