#!/usr/bin/python3
# SPDX-License-Identifier: MIT
"""Figures and tables of the bench-slope study (samples/bench-slope/Makefile).

A STUDY is NAME=DIR: one triangulation of the study, DIR holding run-S1.h5 … run-S3.h5
(dda-run) and stats/summary.h5 (stats over the three runs, named S1, S2, S3).

  report.py cdf SUMMARY.h5 --series S1/R1 S1/R2 ... [--title T] -o FIG.png
      empirical CDFs with DKW bands of runout, lateral, max speed and jump height
  report.py tables STUDY [--toe X] -o TABLES.md
      quantiles per level and block, toe and bench fractions, end reasons
  report.py fractions STUDY [--toe X] -o FRACTIONS.csv
  report.py triangulation STUDY STUDY ... -o TRIANGULATION.csv
      mean lateral ± standard error per level and triangulation, each against the first
  report.py lateral-figure STUDY STUDY ... -o FIG.png
  report.py report STUDY ... [--toe X] [--command C] [--bin DIR] -o REPORT.md
      all tables, with the machine, date and source revision
  report.py verify STUDY ... --realizations N --out DIR
      the checks of `make check`

Quantiles, means and the stop-zone fractions are the ones `stats` wrote (summary.h5);
runout and lateral are over the blocks at rest (stats leaves out the censored ones:
left the terrain or cut by the step limit). The toe fraction counts every realization
whose final centroid is at x >= TOE (default 36 m), from the run files.
Needs matplotlib, h5py and NumPy (Debian python3-matplotlib python3-h5py python3-numpy).
"""
import argparse
import csv
import datetime
import math
import os
import platform
import subprocess
import sys

import h5py
import numpy as np

LEVELS = ["S1", "S2", "S3"]
BLOCKS = ["R1", "R2", "R3", "R4"]
BLOCK_NAMES = {"R1": "tetrahedron", "R2": "cube", "R3": "octahedron", "R4": "dodecahedron"}
CDF_VARIABLES = [("runout", "runout (m)"), ("lateral", "lateral (m)"),
                 ("max_speed", "max speed (m/s)"), ("max_jump_height", "jump height (m)")]
TABLE_VARIABLES = [("runout", "Runout (m, along x from the release point at x = 1 m; blocks at rest)"),
                   ("lateral", "Lateral (m, across the slope, positive towards +y; blocks at rest)"),
                   ("max_speed", "Maximum speed (m/s)"),
                   ("max_jump_height", "Jump height, vertical (m, centroid above the ground after the first touch)"),
                   ("max_normal_jump_height", "Jump height, normal to the ground (m)")]
QUANTILES = [0.05, 0.25, 0.5, 0.75, 0.95, 0.99]
END_REASONS = ["rest", "left_terrain", "step_limit", "non_finite", "no_convergence", "penetration"]
# The bench slope's plan extent (SPEC §6): a block that left the terrain left through the
# edge its final centroid is nearest to.
LENGTH, WIDTH = 60.0, 40.0
EDGES = ["x = 60 m", "y = 40 m", "y = 0", "x = 0"]


def fail(message):
    print("report.py: error: " + message, file=sys.stderr)
    sys.exit(1)


def text(x):
    return x.decode() if isinstance(x, bytes) else str(x)


def study(arg):
    if "=" not in arg:
        fail("%s: expected NAME=DIR" % arg)
    name, path = arg.split("=", 1)
    return name, path


class Summary:
    """The series of one stats summary file, by key 'S1' (a whole run) or 'S1/R4'."""

    def __init__(self, path):
        if not os.path.exists(path):
            fail("%s: missing (run stats first)" % path)
        self.path = path
        self.series = {}
        with h5py.File(path, "r") as f:
            for group in f["series"].values():
                run, block = text(group.attrs["run"]), text(group.attrs["block"])
                key = run if block == "all" else run + "/" + block
                entry = {"realizations": int(group.attrs["realizations"]), "variables": {},
                         "fractions": dict(zip([text(x) for x in group["fraction_names"][:]],
                                               [float(x) for x in group["fraction"][:]]))}
                for v in group["variable"].values():
                    attrs = {k: (text(a) if isinstance(a, (bytes, str)) else a) for k, a in v.attrs.items()}
                    values = v["values"][:] if "values" in v else np.zeros(0)
                    sorted_ = v["sorted"][:] if "sorted" in v else np.zeros(0)
                    quant = dict(zip(v["quantile_p"][:], v["quantile"][:])) if "quantile" in v else {}
                    entry["variables"][attrs["name"]] = dict(attrs, values=values, sorted=sorted_, quantiles=quant)
                self.series[key] = entry

    def get(self, key):
        if key not in self.series:
            fail("%s: no series %s (has %s)" % (self.path, key, ", ".join(sorted(self.series))))
        return self.series[key]


class Run:
    """The records of one run file that the stop-position fractions need."""

    def __init__(self, path):
        if not os.path.exists(path):
            fail("%s: missing (run dda-run first)" % path)
        with h5py.File(path, "r") as f:
            r = f["records"]
            self.block = r["block"][:]
            self.end = r["end_reason"][:].astype(int)
            self.final = r["final_position"][:]
            self.lateral = r["lateral"][:]
            self.realization = r["realization"][:]
            self.blocks = [text(x) for x in f["run/blocks"][:]]
            self.realizations = int(f["run"].attrs["realizations"])

    def select(self, block):
        return np.ones(len(self.block), bool) if block is None else self.block == self.blocks.index(block)

    def toe(self, block, x_toe):
        sel = self.select(block)
        return float(np.mean(self.final[sel, 0] >= x_toe)) if sel.any() else float("nan")

    def exits(self, block=None):
        """How many realizations left the terrain through each edge (EDGES order)."""
        sel = self.select(block) & (self.end == 2)
        x, y = self.final[sel, 0], self.final[sel, 1]
        nearest = np.argmin(np.stack([np.abs(LENGTH - x), np.abs(WIDTH - y), np.abs(y), np.abs(x)]), axis=0)
        return [int(np.sum(nearest == k)) for k in range(len(EDGES))]


def series_keys():
    keys = []
    for level in LEVELS:
        keys.append(level)
        keys += [level + "/" + b for b in BLOCKS]
    return keys


def split_key(key):
    level, _, block = key.partition("/")
    return level, (block or None)


def label(key):
    level, block = split_key(key)
    return "%s %s" % (level, block) if block else "%s all" % level


def load_study(arg):
    name, path = study(arg)
    summary = Summary(os.path.join(path, "stats", "summary.h5"))
    runs = {level: Run(os.path.join(path, "run-%s.h5" % level)) for level in LEVELS}
    return name, summary, runs


def write_atomically(path, content):
    tmp = path + ".tmp-report"
    with open(tmp, "w", newline="") as f:
        f.write(content)
    os.replace(tmp, path)


def fmt(x, digits=2):
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "–"
    return "%.*f" % (digits, x)


def pct(x):
    return "–" if math.isnan(x) else "%.1f" % (100 * x)


# ---------------------------------------------------------------- figures

def pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def draw_ecdf(ax, sorted_values, epsilon, name, color):
    n = len(sorted_values)
    if n == 0:
        return
    x = np.concatenate([[sorted_values[0]], sorted_values])
    f = np.concatenate([[0.0], np.arange(1, n + 1) / n])
    ax.step(x, f, where="post", color=color, label=name, lw=1.4)
    if epsilon and np.isfinite(epsilon):
        ax.fill_between(x, np.clip(f - epsilon, 0, 1), np.clip(f + epsilon, 0, 1), step="post",
                        color=color, alpha=0.12, lw=0)


def cmd_cdf(args):
    plt = pyplot()
    summary = Summary(args.summary)
    fig, axes = plt.subplots(2, 2, figsize=(10, 7.5))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, (var, xlabel) in zip(axes.flat, CDF_VARIABLES):
        for i, key in enumerate(args.series):
            v = summary.get(key)["variables"].get(var)
            if v is None:
                fail("%s: series %s has no variable %s" % (args.summary, key, var))
            level, block = split_key(key)
            name = "%s %s" % (level, block or "all")
            if block:
                name += " (%s)" % BLOCK_NAMES.get(block, block)
            name += ", n = %d" % int(v["n"])
            if int(v.get("censored", 0)):
                name += ", %d censored" % int(v["censored"])
            draw_ecdf(ax, v["sorted"], float(v.get("dkw_epsilon", float("nan"))), name, colors[i % len(colors)])
        if var == "runout":
            # The toe at x = 36 m is 35 m from the release point.
            ax.axvline(35.0, color="0.5", ls=":", lw=1)
        ax.set_xlabel(xlabel)
        ax.set_ylabel("cumulative fraction")
        ax.set_ylim(0, 1)
        ax.grid(alpha=0.3)
    axes.flat[0].legend(fontsize=7.5, loc="upper left")
    fig.suptitle((args.title or "") + "\nshaded: 95 % DKW band; runout and lateral over the blocks at rest; "
                 "dotted: the toe", fontsize=10)
    fig.tight_layout()
    save(fig, args.output)
    plt.close(fig)


def save(fig, path):
    root, ext = os.path.splitext(path)
    tmp = root + ".tmp-report" + ext
    fig.savefig(tmp, dpi=110)
    os.replace(tmp, path)


def lateral_samples(summary, key):
    v = summary.get(key)["variables"]["lateral"]
    return np.asarray(v["values"], float)


def mean_se(x):
    n = len(x)
    if n < 2:
        return float("nan"), float("nan"), float("nan"), n
    sd = float(np.std(x, ddof=1))
    return float(np.mean(x)), sd, sd / math.sqrt(n), n


def lateral_rows(studies):
    """Per triangulation and level (and the three levels pooled): mean lateral, sd, SE, and
    the difference from the first triangulation with its SE, z and two-sided p-value."""
    groups = [(level, [level]) for level in LEVELS] + [("S1-S3", LEVELS)]
    base = {}
    rows = []
    for i, (name, summary, runs) in enumerate(studies):
        for group, levels in groups:
            x = np.concatenate([lateral_samples(summary, level) for level in levels])
            mean, sd, se, n = mean_se(x)
            exits = np.sum([runs[level].exits() for level in levels], axis=0)
            row = {"triangulation": name, "level": group, "n": n, "mean": mean, "sd": sd, "se": se,
                   "z_zero": mean / se if se > 0 else float("nan"),
                   "left_y40": int(exits[1]), "left_y0": int(exits[2])}
            row["p_zero"] = math.erfc(abs(row["z_zero"]) / math.sqrt(2))
            if i == 0:
                base[group] = (mean, se)
                row.update(diff=float("nan"), se_diff=float("nan"), z_diff=float("nan"), p_diff=float("nan"))
            else:
                m0, s0 = base[group]
                diff, se_diff = mean - m0, math.hypot(se, s0)
                z = diff / se_diff
                row.update(diff=diff, se_diff=se_diff, z_diff=z, p_diff=math.erfc(abs(z) / math.sqrt(2)))
            rows.append(row)
    return rows


def cmd_lateral_figure(args):
    plt = pyplot()
    studies = [load_study(s) for s in args.studies]
    rows = lateral_rows(studies)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    fig, axes = plt.subplots(1, 4, figsize=(15, 4.2), gridspec_kw={"width_ratios": [1.3, 1, 1, 1]})
    groups = LEVELS + ["S1-S3"]
    width = 0.8 / max(1, len(studies))
    for i, (name, _, _) in enumerate(studies):
        sub = [r for r in rows if r["triangulation"] == name]
        xs = np.arange(len(groups)) - 0.4 + width * (i + 0.5)
        axes[0].errorbar(xs, [r["mean"] for r in sub], yerr=[1.96 * r["se"] for r in sub], fmt="o",
                         capsize=4, color=colors[i % len(colors)], label=name)
    axes[0].axhline(0, color="0.4", lw=0.8)
    axes[0].set_xticks(np.arange(len(groups)), groups)
    axes[0].set_ylabel("mean lateral (m), ± 1.96 SE")
    axes[0].set_title("mean lateral per level", fontsize=10)
    axes[0].legend(fontsize=8)
    axes[0].grid(alpha=0.3)
    for ax, level in zip(axes[1:], LEVELS):
        for i, (name, summary, _) in enumerate(studies):
            v = summary.get(level)["variables"]["lateral"]
            draw_ecdf(ax, v["sorted"], float("nan"), "%s (n = %d)" % (name, int(v["n"])), colors[i % len(colors)])
        ax.axvline(0, color="0.4", lw=0.8)
        ax.set_title("lateral CDF, %s (all blocks, at rest)" % level, fontsize=10)
        ax.set_xlabel("lateral (m)")
        ax.set_ylim(0, 1)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7.5, loc="upper left")
    fig.suptitle("Lateral drift by triangulation of the grid cells (positive: towards +y)", fontsize=11)
    fig.tight_layout()
    save(fig, args.output)
    plt.close(fig)


# ---------------------------------------------------------------- tables

def quantile_table(summary, var, title):
    v0 = summary.get("S1")["variables"][var]
    has_censored = "censored" in v0
    head = ["series", "n"] + (["censored"] if has_censored else []) + ["mean", "sd"] + \
           ["P%d" % round(100 * p) for p in QUANTILES]
    lines = ["**%s**" % title, "", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for key in series_keys():
        v = summary.get(key)["variables"][var]
        cells = [label(key), "%d" % int(v["n"])] + (["%d" % int(v["censored"])] if has_censored else [])
        cells += [fmt(v.get("mean")), fmt(v.get("sd"))]
        cells += [fmt(quantile(v, p)) for p in QUANTILES]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def fraction_rows(name, summary, runs, toe):
    rows = []
    for key in series_keys():
        level, block = split_key(key)
        s = summary.get(key)
        fr = s["fractions"]
        benches = [fr.get("stop:bench %d" % k, 0.0) for k in (1, 2, 3)]
        exits = runs[level].exits(block)
        rows.append({
            "triangulation": name, "level": level, "block": block or "all", "realizations": s["realizations"],
            "toe": runs[level].toe(block, toe), "bench1": benches[0], "bench2": benches[1], "bench3": benches[2],
            "benches": sum(benches), "slope": fr.get("stop:slope", 0.0),
            "runout_area": fr.get("stop:toe/run-out", 0.0), "out_of_domain": fr.get("stop:out of domain", 0.0),
            "rest": fr.get("end:rest", 0.0), "left_terrain": fr.get("end:left_terrain", 0.0),
            "step_limit": fr.get("end:step_limit", 0.0), "numerical_failure": fr.get("numerical_failure", 0.0),
            "cross_48": fr.get("cross:mid-runout", float("nan")),
            "left_x60": exits[0], "left_y40": exits[1], "left_y0": exits[2], "left_x0": exits[3]})
    return rows


def fraction_table(rows):
    head = ["series", "realizations", "toe (x ≥ 36 m)", "crossed x = 48 m", "bench 1", "bench 2", "bench 3",
            "benches", "slope", "run-out area", "left the terrain", "step limit", "numerical failure",
            "left via x = 60 / y = 40 / y = 0 / x = 0 (count)"]
    lines = ["**Where the blocks stopped (% of the realizations)**", "",
             "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        key = r["level"] if r["block"] == "all" else r["level"] + "/" + r["block"]
        lines.append("| " + " | ".join([label(key), "%d" % r["realizations"]] + [pct(r[k]) for k in (
            "toe", "cross_48", "bench1", "bench2", "bench3", "benches", "slope", "runout_area", "out_of_domain",
            "step_limit", "numerical_failure")] + ["%d / %d / %d / %d" % (
                r["left_x60"], r["left_y40"], r["left_y0"], r["left_x0"])]) + " |")
    return "\n".join(lines) + "\n"


def quantile(v, p):
    match = [val for pp, val in v["quantiles"].items() if abs(pp - p) < 1e-9]
    return float(match[0]) if match else float("nan")


def summary_table(summary, rows):
    """One line per series: the figures a reader compares first."""
    head = ["series", "runout P50 / P95 (m)", "lateral mean / P5 / P95 (m)", "max speed P50 / P95 (m/s)",
            "jump height P50 / P95 (m)", "toe", "crossed x = 48 m", "benches", "left the terrain"]
    lines = ["**Summary**", "", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for key, r in zip(series_keys(), rows):
        v = summary.get(key)["variables"]
        ro, la, sp, ju = v["runout"], v["lateral"], v["max_speed"], v["max_jump_height"]
        lines.append("| " + " | ".join([
            label(key),
            "%s / %s" % (fmt(quantile(ro, 0.5), 1), fmt(quantile(ro, 0.95), 1)),
            "%s / %s / %s" % (fmt(la.get("mean"), 2), fmt(quantile(la, 0.05), 1), fmt(quantile(la, 0.95), 1)),
            "%s / %s" % (fmt(quantile(sp, 0.5), 1), fmt(quantile(sp, 0.95), 1)),
            "%s / %s" % (fmt(quantile(ju, 0.5), 2), fmt(quantile(ju, 0.95), 2)),
            pct(r["toe"]) + " %", pct(r["cross_48"]) + " %", pct(r["benches"]) + " %",
            pct(r["left_terrain"]) + " %"]) + " |")
    return "\n".join(lines) + "\n"


def study_tables(arg, toe):
    name, summary, runs = load_study(arg)
    rows = fraction_rows(name, summary, runs, toe)
    parts = ["### Triangulation: %s\n" % name, summary_table(summary, rows)]
    for var, title in TABLE_VARIABLES:
        parts.append(quantile_table(summary, var, title))
    parts.append(fraction_table(rows))
    return "\n".join(parts)


def cmd_tables(args):
    write_atomically(args.output, study_tables(args.study, args.toe))


FRACTION_FIELDS = ["triangulation", "level", "block", "realizations", "toe", "cross_48", "bench1", "bench2",
                   "bench3", "benches", "slope", "runout_area", "out_of_domain", "rest", "left_terrain", "step_limit",
                   "numerical_failure", "left_x60", "left_y40", "left_y0", "left_x0"]


def cmd_fractions(args):
    name, summary, runs = load_study(args.study)
    rows = fraction_rows(name, summary, runs, args.toe)
    tmp = args.output + ".tmp-report"
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, FRACTION_FIELDS, lineterminator="\n")
        w.writeheader()
        for r in rows:
            w.writerow({k: ("%.6g" % v if isinstance(v, float) else v) for k, v in r.items()})
    os.replace(tmp, args.output)


LATERAL_FIELDS = ["triangulation", "level", "n", "mean", "sd", "se", "z_zero", "p_zero", "diff", "se_diff",
                  "z_diff", "p_diff", "left_y40", "left_y0"]


def cmd_triangulation(args):
    rows = lateral_rows([load_study(s) for s in args.studies])
    tmp = args.output + ".tmp-report"
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, LATERAL_FIELDS, lineterminator="\n")
        w.writeheader()
        for r in rows:
            w.writerow({k: ("%.6g" % v if isinstance(v, float) else v) for k, v in r.items()})
    os.replace(tmp, args.output)


def lateral_table(rows, first):
    head = ["triangulation", "level", "n (at rest)", "mean lateral ± SE (m)", "sd (m)", "z against 0",
            "p against 0", "difference from %s ± SE (m)" % first, "z", "p", "left via y = 40 m / y = 0"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        diff = "–" if math.isnan(r["diff"]) else "%+.2f ± %.2f" % (r["diff"], r["se_diff"])
        lines.append("| " + " | ".join([
            r["triangulation"], r["level"], "%d" % r["n"], "%+.2f ± %.2f" % (r["mean"], r["se"]), fmt(r["sd"]),
            "%+.1f" % r["z_zero"], "%.2g" % r["p_zero"], diff,
            "–" if math.isnan(r["z_diff"]) else "%+.1f" % r["z_diff"],
            "–" if math.isnan(r["p_diff"]) else "%.2g" % r["p_diff"],
            "%d / %d" % (r["left_y40"], r["left_y0"])]) + " |")
    return "\n".join(lines) + "\n"


def ks(a, b):
    """Two-sample Kolmogorov-Smirnov distance and its asymptotic p-value (Stephens), as stats."""
    a, b = np.sort(a), np.sort(b)
    if len(a) == 0 or len(b) == 0:
        return float("nan"), float("nan")
    grid = np.concatenate([a, b])
    d = float(np.max(np.abs(np.searchsorted(a, grid, "right") / len(a) - np.searchsorted(b, grid, "right") / len(b))))
    ne = len(a) * len(b) / (len(a) + len(b))
    lam = (math.sqrt(ne) + 0.12 + 0.11 / math.sqrt(ne)) * d
    if lam < 1e-3:
        return d, 1.0
    p = 2 * sum((-1) ** (k - 1) * math.exp(-2 * k * k * lam * lam) for k in range(1, 101))
    return d, min(1.0, max(0.0, p))


def other_outputs_table(studies, toe):
    """Each triangulation against the first: KS distance (p) of the four CDF variables and the toe
    fraction, per level (all blocks)."""
    first_name, first_summary, first_runs = studies[0]
    head = ["triangulation", "level"] + ["%s KS (p)" % var for var, _ in CDF_VARIABLES] + \
           ["toe fraction (%s → this)" % first_name]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, summary, runs in studies[1:]:
        for level in LEVELS:
            cells = [name, level]
            for var, _ in CDF_VARIABLES:
                d, p = ks(first_summary.get(level)["variables"][var]["values"],
                          summary.get(level)["variables"][var]["values"])
                cells.append("%.3f (%.2g)" % (d, p))
            t0, t1 = first_runs[level].toe(None, toe), runs[level].toe(None, toe)
            n0, n1 = len(first_runs[level].end), len(runs[level].end)
            se = math.sqrt(t0 * (1 - t0) / n0 + t1 * (1 - t1) / n1)
            cells.append("%.1f → %.1f %% (± %.1f)" % (100 * t0, 100 * t1, 100 * se))
            lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def spread_table(studies, toe):
    """Lateral spread per triangulation and level: all blocks at rest, and those at rest past the toe."""
    head = ["triangulation", "level", "lateral sd ± SE (m), at rest", "P5 … P95 (m)", "sd past the toe ± SE (m)",
            "sd on the benches (m)", "left via the sides"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, summary, runs in studies:
        for level in LEVELS:
            v = summary.get(level)["variables"]["lateral"]
            run = runs[level]
            rest = run.end == 1
            past = run.lateral[rest & (run.final[:, 0] >= toe)]
            before = run.lateral[rest & (run.final[:, 0] < toe)]
            exits = run.exits()

            def sd_se(x):
                if len(x) < 2:
                    return "–"
                sd = float(np.std(x, ddof=1))
                return "%.2f ± %.2f (n = %d)" % (sd, sd / math.sqrt(2 * (len(x) - 1)), len(x))
            lines.append("| " + " | ".join([
                name, level, sd_se(np.asarray(v["values"])), "%s … %s" % (fmt(quantile(v, 0.05), 1),
                                                                      fmt(quantile(v, 0.95), 1)),
                sd_se(past), fmt(float(np.std(before, ddof=1)) if len(before) > 1 else float("nan")),
                "%d" % (exits[1] + exits[2])]) + " |")
    return "\n".join(lines) + "\n"


def machine():
    cpu = "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return "%s, %d cores (nproc %s), %s" % (cpu, os.cpu_count() or 0, len(os.sched_getaffinity(0)),
                                          platform.platform())


def revision():
    root = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
    try:
        out = subprocess.run(["git", "-C", root, "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                             timeout=10)
        if out.returncode == 0:
            dirty = subprocess.run(["git", "-C", root, "status", "--porcelain", "--untracked-files=no"],
                                   capture_output=True, text=True, timeout=10).stdout.strip()
            return out.stdout.strip() + (" (with local changes)" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        pass
    return "unknown (not a git checkout)"


def cmd_report(args):
    studies = [load_study(s) for s in args.studies]
    first = studies[0]
    n = first[2]["S1"].realizations
    parts = ["# Bench-slope study (SPEC §6)", "",
             "- realizations: %d per level and triangulation (%d per block)" % (n, n // 4),
             "- triangulations: %s" % ", ".join(s[0] for s in studies),
             "- written %s on %s" % (datetime.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M %Z"), machine()),
             "- source revision: %s; tools: %s" % (revision(), args.bin or "?"),
             "- regenerate: `%s`" % args.command, "",
             "Runout and lateral over the blocks at rest; speed and jump height over every realization "
             "without a numerical failure. Toe: final centroid at x ≥ %g m." % args.toe, "",
             "## Lateral drift by triangulation", "",
             "Mean lateral over the blocks at rest; the last column counts the blocks that left the "
             "terrain through its side edges (left out of the mean).", "",
             lateral_table(lateral_rows(studies), first[0]), ""]
    if len(studies) > 1:
        parts += ["## Other outputs by triangulation", "",
                  "Each triangulation against %s, all blocks of a level: two-sample KS distance "
                  "(asymptotic p-value) and toe fraction (± standard error of the difference)." % first[0], "",
                  other_outputs_table(studies, args.toe), ""]
    parts += ["## Lateral spread by roughness", "",
              "Standard deviation of the lateral position of the blocks at rest (SE ≈ sd/√(2(n − 1))), "
              "all of them and those past the toe (x ≥ %g m), and the blocks that left through the side "
              "edges (the widest, left out)." % args.toe, "",
              spread_table(studies, args.toe), ""]
    for arg in args.studies:
        parts.append("## " + study_tables(arg, args.toe).lstrip("# "))
    write_atomically(args.output, "\n".join(parts))


# ---------------------------------------------------------------- make check

def cmd_verify(args):
    problems = []
    n = args.realizations
    for arg in args.studies:
        name, summary, runs = load_study(arg)
        _, path = study(arg)
        for level, run in runs.items():
            if run.realizations != n or len(run.end) != n:
                problems.append("%s run-%s: %d records, %d expected" % (name, level, len(run.end), n))
            if sorted(run.realization.tolist()) != list(range(len(run.end))):
                problems.append("%s run-%s: realizations are not 0 … %d" % (name, level, n - 1))
            counts = np.bincount(run.block, minlength=len(run.blocks))
            if run.blocks != BLOCKS or counts.max() - counts.min() > 1:
                problems.append("%s run-%s: blocks %s, counts %s (expected R1-R4 in turn)" % (
                    name, level, run.blocks, counts.tolist()))
            if not np.all((run.end >= 1) & (run.end <= len(END_REASONS))):
                problems.append("%s run-%s: realization without an end reason" % (name, level))
        for key in series_keys():
            s = summary.get(key)
            fr = s["fractions"]
            total = sum(v for k, v in fr.items() if k.startswith("stop:")) + fr.get("end:step_limit", 0) + \
                fr.get("numerical_failure", 0)
            if abs(total - 1) > 1e-9:
                problems.append("%s %s: stop fractions add up to %.6f" % (name, key, total))
            for var, _ in CDF_VARIABLES:
                v = s["variables"].get(var)
                if v is None:
                    problems.append("%s %s: no %s" % (name, key, var))
                elif len(v["sorted"]) != int(v["n"]) or not np.all(np.isfinite(v["sorted"])):
                    problems.append("%s %s: %s has %d finite values of %d" % (
                        name, key, var, int(np.isfinite(v["sorted"]).sum()), int(v["n"])))
            # The stats tool's reach fraction at 35 m from the release (x = 36 m) is the toe fraction.
            level, block = split_key(key)
            toe = runs[level].toe(block, 36.0)
            if abs(fr.get("runout>=35", -1) - toe) > 1e-12:
                problems.append("%s %s: toe fraction %.4f, stats' runout>=35 %.4f" % (
                    name, key, toe, fr.get("runout>=35", -1)))
        files = ["stats/table.csv", "stats/summary.csv", "tables.md", "fractions.csv",
                 "figures/cdf-shapes-S1.png", "figures/cdf-R4-S1-S3.png"]
        if args.stats_plots == "true":
            files += ["stats/plots/cdf-%s.png" % var for var, _ in CDF_VARIABLES]
        for rel in files:
            check_file(os.path.join(path, rel), problems)
    for rel in ["triangulation.csv", "lateral-triangulation.png", "report.md"]:
        check_file(os.path.join(args.out, rel), problems)
    with open(os.path.join(args.out, "triangulation.csv")) as f:
        rows = list(csv.DictReader(f))
    if len(rows) != 4 * len(args.studies):
        problems.append("triangulation.csv: %d rows, %d expected" % (len(rows), 4 * len(args.studies)))
    for p in problems:
        print("bench-slope: check: " + p, file=sys.stderr)
    if problems:
        sys.exit(1)
    print("bench-slope: check: %d studies of %d realizations per level: run files, statistics, figures and "
          "tables complete" % (len(args.studies), n))


def check_file(path, problems):
    if not os.path.isfile(path) or os.path.getsize(path) == 0:
        problems.append("%s: missing or empty" % path)
    elif path.endswith(".png"):
        with open(path, "rb") as f:
            if f.read(8) != b"\x89PNG\r\n\x1a\n":
                problems.append("%s: not a PNG file" % path)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="subcommand", required=True)
    s = sub.add_parser("cdf")
    s.add_argument("summary")
    s.add_argument("--series", nargs="+", required=True)
    s.add_argument("--title")
    s.add_argument("-o", "--output", required=True)
    for cmd in ("tables", "fractions"):
        s = sub.add_parser(cmd)
        s.add_argument("study", metavar="NAME=DIR")
        s.add_argument("--toe", type=float, default=36.0, help="x of the toe (m), default 36")
        s.add_argument("-o", "--output", required=True)
    for cmd in ("triangulation", "lateral-figure"):
        s = sub.add_parser(cmd)
        s.add_argument("studies", nargs="+", metavar="NAME=DIR")
        s.add_argument("-o", "--output", required=True)
    s = sub.add_parser("report")
    s.add_argument("studies", nargs="+", metavar="NAME=DIR")
    s.add_argument("--toe", type=float, default=36.0)
    s.add_argument("--command", default="make -j2 -C samples/bench-slope", help="the command that wrote it")
    s.add_argument("--bin")
    s.add_argument("-o", "--output", required=True)
    s = sub.add_parser("verify")
    s.add_argument("studies", nargs="+", metavar="NAME=DIR")
    s.add_argument("--realizations", type=int, required=True)
    s.add_argument("--stats-plots", choices=["true", "false"], default="true")
    s.add_argument("--out", required=True)
    args = p.parse_args()
    {"cdf": cmd_cdf, "tables": cmd_tables, "fractions": cmd_fractions, "triangulation": cmd_triangulation,
     "lateral-figure": cmd_lateral_figure, "report": cmd_report, "verify": cmd_verify}[args.subcommand](args)


if __name__ == "__main__":
    main()
