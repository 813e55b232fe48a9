#!/usr/bin/python3
"""Summary and comparison tables of reference-study run files (docs/reference-study.md).

  compare_runs.py summary NAME=RUN.h5 ...
      one row per series (run x block): runout P50/P95 and lateral P95 over the blocks
      at rest, max speed P50, jump P95 (vertical / normal), bench stops, toe fraction.
  compare_runs.py compare NAME=BEFORE.h5,AFTER.h5 ...
      ends and toe fraction per run, then per series and variable the two-sample
      Kolmogorov-Smirnov distance and the P50 and P95 before -> after.

Runout and lateral over the realizations that ended at rest; speeds and jumps over every
realization that did not fail. Toe: final centroid at x >= TOE (default 36 m, --toe).
Benches: stop classes whose name starts with "bench". Markdown on stdout. Needs h5py and
numpy (Debian python3-h5py, python3-numpy).
"""
import argparse
import sys

import h5py
import numpy as np

END_REASONS = ["rest", "left_terrain", "step_limit", "non_finite", "no_convergence", "penetration"]
FAILED = [4, 5, 6]


def names(ds):
    return [x.decode() if isinstance(x, bytes) else str(x) for x in ds[:]]


def load(path):
    with h5py.File(path, "r") as f:
        r = f["records"]
        out = {k: r[k][:] for k in r.keys()}
        out["_blocks"] = names(f["run/blocks"])
        out["_classes"] = names(f["run/stop_classes"])
    return out


def ks(a, b):
    a, b = np.sort(a), np.sort(b)
    if not len(a) or not len(b):
        return float("nan")
    grid = np.concatenate([a, b])
    return float(np.max(np.abs(np.searchsorted(a, grid, "right") / len(a) - np.searchsorted(b, grid, "right") / len(b))))


def q(x, p):
    return float(np.percentile(x, p)) if len(x) else float("nan")


def series(run, toe):
    """(block name, dict of samples and fractions) per block of the run."""
    out = []
    bench = [i for i, c in enumerate(run["_classes"]) if c.startswith("bench")]
    for b, name in enumerate(run["_blocks"]):
        sel = run["block"] == b
        if not sel.any():
            continue
        end = run["end_reason"][sel]
        rest = end == 1
        ok = ~np.isin(end, FAILED)
        out.append((name, {
            "runout": run["runout"][sel][rest], "lateral": run["lateral"][sel][rest],
            "max_speed": run["max_speed"][sel][ok], "max_jump_height": run["max_jump_height"][sel][ok],
            # Absent from run files written before the normal-to-slope jump existed.
            "max_normal_jump_height": run["max_normal_jump_height"][sel][ok] if "max_normal_jump_height" in run
            else np.full(int(ok.sum()), np.nan),
            "bench": float(np.mean(np.isin(run["stop_class"][sel], bench))),
            "toe": float(np.mean(run["final_position"][sel][:, 0] >= toe)),
        }))
    return out


def ends(run):
    counts = np.bincount(run["end_reason"].astype(int), minlength=7)[1:]
    return ", ".join("%s %d" % (r, c) for r, c in zip(END_REASONS, counts) if c)


def cmd_summary(args):
    print("| level | block | runout P50 (m) | runout P95 (m) | \|lateral\| P95 (m) | max speed P50 (m/s) "
          "| jump P95 vertical / normal (m) | bench 1–3 stops | toe fraction |")
    print("|---|---|---|---|---|---|---|---|---|")
    for item in args.runs:
        name, path = item.split("=", 1)
        run = load(path)
        for block, s in series(run, args.toe):
            print("| %s | %s | %.1f | %.1f | %.1f | %.1f | %.2f / %.2f | %.0f %% | %.0f %% |" % (
                name, block, q(s["runout"], 50), q(s["runout"], 95), q(np.abs(s["lateral"]), 95),
                q(s["max_speed"], 50), q(s["max_jump_height"], 95), q(s["max_normal_jump_height"], 95),
                100 * s["bench"], 100 * s["toe"]))
    print()
    print("| level | ends | toe fraction (all blocks) | bench stops (all blocks) |")
    print("|---|---|---|---|")
    for item in args.runs:
        name, path = item.split("=", 1)
        run = load(path)
        bench = [i for i, c in enumerate(run["_classes"]) if c.startswith("bench")]
        print("| %s | %s | %.1f %% | %.1f %% |" % (name, ends(run), 100 * np.mean(run["final_position"][:, 0] >= args.toe),
                                                  100 * np.mean(np.isin(run["stop_class"], bench))))


def cmd_compare(args):
    pairs = []
    for item in args.pairs:
        name, paths = item.split("=", 1)
        before, after = paths.split(",", 1)
        pairs.append((name, load(before), load(after)))
    print("| series | ends before | ends after | toe fraction before → after |")
    print("|---|---|---|---|")
    for name, a, b in pairs:
        print("| %s | %s | %s | %.1f %% → %.1f %% |" % (name, ends(a), ends(b), 100 * np.mean(a["final_position"][:, 0] >= args.toe),
                                                     100 * np.mean(b["final_position"][:, 0] >= args.toe)))
    print()
    print("| series | variable | KS distance | P50 before → after | P95 before → after |")
    print("|---|---|---|---|---|")
    for name, a, b in pairs:
        sb = dict(series(b, args.toe))
        for var in ("runout", "lateral", "max_speed", "max_jump_height"):
            for block, s in series(a, args.toe):
                if block not in sb:
                    continue
                x, y = s[var], sb[block][var]
                print("| %s %s | %s | %.2f | %.2f → %.2f | %.2f → %.2f |" % (
                    name, block, var, ks(x, y), q(x, 50), q(y, 50), q(x, 95), q(y, 95)))


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--toe", type=float, default=36.0, help="x of the toe (m), default 36")
    sub = p.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("summary")
    s.add_argument("runs", nargs="+", metavar="NAME=RUN.h5")
    s = sub.add_parser("compare")
    s.add_argument("pairs", nargs="+", metavar="NAME=BEFORE.h5,AFTER.h5")
    args = p.parse_args()
    {"summary": cmd_summary, "compare": cmd_compare}[args.cmd](args)


if __name__ == "__main__":
    sys.exit(main())
