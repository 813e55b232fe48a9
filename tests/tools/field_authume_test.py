#!/usr/bin/python3
"""bench/field/authume.py on a synthetic dataset laid out as the Authume data (y-up STL
zones and blocks, drop points, orientations, measured stops), so the field validation runs
from a clean clone without the data: the table's measured quantiles are the synthetic
stops', every realization is accounted for, the censored KS distance is exact on small
cases, the observed stops written for calibrate are the data's in plan, and a folder
that is not the dataset is a one-line error.

  field_authume_test.py --bin build/bin --out DIR
"""

import argparse
import importlib.util
import os
import shutil
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPT = os.path.join(HERE, "..", "..", "bench", "field", "authume.py")


def elevation(x):
    """A slope of 0.6 down to x = 40 m, then a flat floor (data's y up)."""
    return 212.0 - 0.6 * min(x, 40.0)


def write_zone(path, x0, x1, z0=340.0, z1=420.0, cell=2.0):
    xs = np.arange(x0, x1 + 1e-9, cell)
    zs = np.arange(z0, z1 + 1e-9, cell)
    with open(path, "w") as f:
        f.write("solid zone\n")
        for i in range(len(xs) - 1):
            for j in range(len(zs) - 1):
                a, b = (xs[i], zs[j]), (xs[i + 1], zs[j])
                c, d = (xs[i + 1], zs[j + 1]), (xs[i], zs[j + 1])
                for tri in ((a, b, c), (a, c, d)):
                    f.write("facet normal 0 0 0\nouter loop\n")
                    for x, z in tri:
                        f.write(f"vertex {x} {elevation(x)} {z}\n")
                    f.write("endloop\nendfacet\n")
        f.write("endsolid zone\n")


def write_box(path, a, b, c):
    v = [(sx * a / 2, sy * b / 2, sz * c / 2) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    with open(path, "w") as f:
        f.write("solid box\n")
        for q in quads:
            for tri in ((q[0], q[1], q[2]), (q[0], q[2], q[3])):
                f.write("facet normal 0 0 0\nouter loop\n")
                for k in tri:
                    f.write("vertex {} {} {}\n".format(*v[k]))
                f.write("endloop\nendfacet\n")
        f.write("endsolid box\n")


def make_dataset(root):
    stl = os.path.join(root, "Geometries", "STL")
    os.makedirs(stl)
    os.makedirs(os.path.join(root, "Drop_conditions"))
    os.makedirs(os.path.join(root, "EXP_endpoints"))
    write_zone(os.path.join(stl, "DTM_Gray_zone.stl"), -10.0, 14.0)
    write_zone(os.path.join(stl, "DTM_Red_zone.stl"), 14.0, 40.0)
    write_zone(os.path.join(stl, "DTM_Blue_zone.stl"), 40.0, 120.0)
    for name, dims in (("SP1A", (0.8, 0.6, 0.4)), ("SP2A", (1.2, 1.0, 0.7)), ("SP2B", (1.4, 1.1, 0.8)),
                       ("SP3A", (1.1, 0.5, 0.4))):
        write_box(os.path.join(stl, name + ".stl"), *dims)
    rng = np.random.default_rng(3)
    with open(os.path.join(root, "Drop_conditions", "orientations.txt"), "w") as f:
        f.write("q0\tq1\tq2\tq3\n")
        for q in rng.normal(size=(8, 4)):
            f.write("\t".join(f"{v:.10f}" for v in q / np.linalg.norm(q)) + "\n")
    stops = {}
    for profile, z in (("P1", 370.0), ("P2", 390.0)):
        with open(os.path.join(root, "Drop_conditions", f"positions_{profile}.xyz"), "w") as f:
            for dx, dz in ((1.0, 1.0), (1.0, -1.0), (-1.0, -1.0), (-1.0, 1.0)):
                f.write(f"{2.0 + dx} {elevation(2.0) + 1.5} {z + dz}\n")
        xs = 45.0 + 20.0 * rng.random(12)
        zs = z + 6.0 * rng.normal(size=12)
        with open(os.path.join(root, "EXP_endpoints", f"Endpoints_{profile}.txt"), "w") as f:
            for x, zz in zip(xs, zs):
                f.write(f"{x:.3f} {elevation(x):.3f} {zz:.3f} 900 1.1 0.8 0.6\n")
        stops[profile] = np.hypot(xs - 2.0, zs - z)
    return stops


def check(condition, message):
    if not condition:
        sys.exit(f"field_authume_test: {message}")


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--bin", required=True)
    p.add_argument("--out", required=True)
    args = p.parse_args()
    shutil.rmtree(args.out, ignore_errors=True)
    os.makedirs(args.out)

    spec = importlib.util.spec_from_file_location("authume", SCRIPT)
    authume = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(authume)
    # Censored KS: one simulated block of four not at rest lies beyond every measured stop.
    m = np.array([1.0, 2.0, 3.0])
    s = np.array([1.0, 2.0, 3.0, 2.5])
    check(abs(authume.ks_censored(m, s, np.array([True, True, True, False])) - 0.25) < 1e-12, "censored KS of 1 in 4 away")
    check(authume.ks_censored(m, s[:3], np.ones(3, dtype=bool)) == 0.0, "KS of equal samples")
    check(abs(authume.ks_censored(m, s[:3] + 10.0, np.ones(3, dtype=bool)) - 1.0) < 1e-12, "KS of disjoint samples")

    data = os.path.join(args.out, "data")
    stops = make_dataset(data)
    out = os.path.join(args.out, "run")
    r = subprocess.run([sys.executable, SCRIPT, "--data", data, "--bin", args.bin, "--out", out, "--realizations", "32",
                        "--threads", "2"], capture_output=True, text=True)
    check(r.returncode == 0, f"authume.py failed: {r.stderr.strip()}")
    rows = [line for line in open(os.path.join(out, "table.md")).read().splitlines()[2:] if line.startswith("|")]
    check(len(rows) == 4, f"expected 4 rows (2 material sets x 2 profiles), got {len(rows)}")
    for row in rows:
        cells = [c.strip() for c in row.strip("|").split("|")]
        materials, profile = cells[0], cells[1]
        rest = int(cells[2].split(" of ")[0])
        check(cells[2].split(" of ")[1].startswith("32 "), f"{materials} {profile}: not 32 realizations: {cells[2]}")
        measured = [float(v) for v in cells[3].split(" / ")]
        expected = np.quantile(stops[profile], [0.1, 0.5, 0.9])
        check(np.allclose(measured, expected, atol=0.051), f"{profile}: measured quantiles {measured} != {expected}")
        ks = float(cells[7])
        check(0.0 <= ks <= 1.0, f"{materials} {profile}: KS {ks}")
        check(rest >= 1, f"{materials} {profile}: no block at rest")
    check(os.path.getsize(os.path.join(out, "stops.png")) > 10000, "no overlay plot")
    # calibrate's observed stops: the data's y-up (x, z) as plan (x, -z), and a settings
    # file calibrate reads (--print-config parses it: an unknown key or a bad value fails).
    rows = open(os.path.join(out, "observed-P1.csv")).read().splitlines()
    first = [float(v) for v in open(os.path.join(data, "EXP_endpoints", "Endpoints_P1.txt")).readline().split()]
    check(rows[0] == "x,y" and len(rows) == 13 and
          np.allclose([float(v) for v in rows[1].split(",")], [first[0], -first[2]], atol=1e-3),
          f"observed-P1.csv: {rows[:2]}")
    r = subprocess.run([os.path.join(args.bin, "calibrate"), "-c", os.path.join(out, "calibrate-P1.yaml"),
                        "--print-config"], capture_output=True, text=True)
    check(r.returncode == 0 and "variables: distance" in r.stdout, f"calibrate-P1.yaml: {r.stderr.strip()}")
    # The contact-point law and each profile's calibration predicting both profiles.
    out = os.path.join(args.out, "calibrated")
    r = subprocess.run([sys.executable, SCRIPT, "--data", data, "--bin", args.bin, "--out", out, "--realizations", "16",
                        "--threads", "2", "--materials", "classes", "--law", "point", "--calibrate",
                        "--calibration", "4", "8", "2"], capture_output=True, text=True)
    check(r.returncode == 0, f"authume.py --calibrate failed: {r.stderr.strip()}")
    check("restitution: point" in open(os.path.join(out, "classes-P2.yaml")).read(), "scene without the law")
    check("parameter: ploughing" in open(os.path.join(out, "calibrate-P1.yaml")).read(), "no ploughing fitted")
    rows = [line.split("|")[1:3] for line in open(os.path.join(out, "table.md")).read().splitlines()[2:]]
    keys = sorted((a.strip(), b.strip()) for a, b in rows)
    check(keys == sorted((m, p) for m in ("classes", "calibrated on P1", "calibrated on P2") for p in ("P1", "P2")),
          f"rows {keys}")
    fitted = authume.fitted_medians(os.path.join(out, "fit-P1", "summary.csv"))
    scene = open(os.path.join(out, "calibrated-on-P1-P2.yaml")).read()
    check(f"ploughing: {fitted['DTM_Gray_zone']['ploughing']:.6g}" in scene, "P2 scene without P1's fitted medians")
    # Not the dataset: one line naming the file.
    r = subprocess.run([sys.executable, SCRIPT, "--data", args.out, "--bin", args.bin, "--out", out],
                       capture_output=True, text=True)
    check(r.returncode != 0 and r.stderr.count("\n") == 1 and "DTM_Gray_zone.stl: missing" in r.stderr,
          f"a folder without the data: {r.stderr!r}")
    print("field_authume_test: passed")


if __name__ == "__main__":
    main()
