#!/usr/bin/python3
"""Mesh convergence of a study's outputs: the same three rock shapes at about 200, 1 280,
5 120 and 20 480 faces, each run on the bench slope at S2 through terrain-gen, block-gen
and dda-run, and their distributions compared level against level (docs/block.md,
"Level of detail").

Shapes (1 m^3 each):
  ellipsoid  an ellipsoid 1 : 0.7 : 0.5 (block-gen `ellipsoid`, resolution 3, 8, 16, 32)
  rough      a rough, concave rock: the ellipsoid 1.4 x 1.1 x 0.9 m with 40 bumps and
             dents (`roughness` 0.15), the same shape at every resolution
  rounded    a cube with rounded edges and corners (the cube of edge 0.8 m swept by a
             sphere of 0.1 m): the convex hull of its support points in the directions of
             a geodesic grid of 20 n^2 triangles, n = 3, 8, 16, 32
Per shape and level: the ends, the share past the toe (x >= 36 m), medians of runout,
maximum speed and jump height, impacts per realization; then, between every two of the
three finer levels, the two-sample Kolmogorov-Smirnov distance of runout and lateral
offset (blocks at rest), maximum speed, jump height and final x (all), against the 5 %
critical value 1.358 sqrt((n + m) / (n m)).

Usage:
  mesh_convergence.py --bin build/bin --out DIR [--realizations 1000] [--set KEY=VALUE ...]
                      [--shapes ellipsoid rough rounded] [--levels 3 8 16 32] [--check] [--fresh]
`--set` is passed to every dda-run (e.g. engine.smooth_turn_deg=0). The terrain, block and
run files found in DIR are reused (an interrupted benchmark goes on); `--fresh` removes them
first. Prints Markdown and
writes it to DIR/convergence.md. The pairs compared are those of the levels given but the
coarsest (3: about 200 faces, a different shape). `--check` exits 1 unless, for every
pair, every KS distance is within its 5 % critical value, the shares past the toe differ
by no more than a two-proportion test allows at 5 % (1.96 standard errors), and no
realization failed or met the time limit. Only the standard library, numpy and h5py.
"""
import argparse
import math
import os
import sys

import h5py
import numpy as np

from logged_run import run

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
LEVELS = [3, 8, 16, 32]
SHAPES = ["ellipsoid", "rough", "rounded"]
TOE = 36.0  # the bench slope's toe (m): a block past it has final x >= TOE


def geodesic_directions(n):
    """Unit vertices of the icosahedron's triangles split n times along each edge."""
    t = (1.0 + math.sqrt(5.0)) / 2.0
    v = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
                  [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], dtype=float)
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2),
             (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11),
             (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    points = []
    for a, b, c in faces:
        for i in range(n + 1):
            for j in range(n + 1 - i):
                k = n - i - j
                p = (i * v[a] + j * v[b] + k * v[c]) / n
                points.append(p / np.linalg.norm(p))
    return np.unique(np.round(np.array(points), 12), axis=0)


def write_inputs(out, log):
    rounded = []
    for n in LEVELS:
        path = os.path.join(out, f"rounded-{n}.xyz")
        d = geodesic_directions(n)
        # The support point of the rounded cube along d: the core cube's corner (or edge,
        # face) that way, plus the sphere's radius along d.
        p = 0.4 * np.sign(np.where(np.abs(d) < 1e-12, 0.0, d)) + 0.1 * d
        np.savetxt(path, np.unique(np.round(p, 12), axis=0), fmt="%.12f")
        rounded.append(path)
    lines = ["density: 2800", "blocks:"]
    for n in LEVELS:
        lines.append(f"  - {{name: ellipsoid-{n}, solid: ellipsoid, dimensions: [1.6, 1.12, 0.8], volume: 1, resolution: {n}}}")
        lines.append(f"  - {{name: rough-{n}, solid: ellipsoid, dimensions: [1.4, 1.1, 0.9], volume: 1, resolution: {n},"
                     " roughness: 0.15, seed: 7}")
        lines.append(f"  - {{name: rounded-{n}, cloud: {os.path.abspath(rounded[LEVELS.index(n)])}, volume: 1,"
                     " input: {reconstruction: hull}}")
    config = os.path.join(out, "blocks.yaml")
    with open(config, "w") as f:
        f.write("\n".join(lines) + "\n")
    return config


def ks(a, b):
    a, b = np.sort(a), np.sort(b)
    if len(a) == 0 or len(b) == 0:
        return float("nan")
    x = np.concatenate([a, b])
    return float(np.max(np.abs(np.searchsorted(a, x, side="right") / len(a) - np.searchsorted(b, x, side="right") / len(b))))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--realizations", type=int, default=1000)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--set", action="append", default=[], help="KEY=VALUE passed to every dda-run")
    ap.add_argument("--fresh", action="store_true", help="remove the outputs of an earlier run in --out first")
    ap.add_argument("--shapes", nargs="+", default=SHAPES, choices=SHAPES)
    ap.add_argument("--levels", nargs="+", type=int, default=LEVELS, choices=LEVELS)
    ap.add_argument("--check", action="store_true", help="exit 1 unless the levels agree (see above)")
    args = ap.parse_args()
    levels = sorted(set(args.levels))
    compared = [n for n in levels if n != LEVELS[0]]
    problems = []
    os.makedirs(args.out, exist_ok=True)
    log = os.path.join(args.out, "log.txt")
    terrain = os.path.join(args.out, "terrain-S2.h5")
    if args.fresh:
        # Earlier outputs are reused otherwise: after an engine change they would be stale.
        for name in os.listdir(args.out):
            if name.endswith((".h5", ".xmf", ".xyz", ".yaml", ".journal", ".lock")):
                os.remove(os.path.join(args.out, name))
    if not os.path.exists(terrain):
        run([f"{args.bin}/terrain-gen", "-c", os.path.join(REPO, "samples/bench-slope/terrain.yaml"), "-o", terrain], log)
    blocks = os.path.join(args.out, "blocks.h5")
    if not os.path.exists(blocks):
        run([f"{args.bin}/block-gen", "-c", write_inputs(args.out, log), "-o", blocks], log)
    faces = {}
    with h5py.File(blocks) as f:
        for g in f["blocks"].values():
            faces[g.attrs["name"]] = len(g["face_offsets"]) - 1
    extra = []
    for kv in args.set:
        extra += ["--set", kv]
    data = {}
    for shape in args.shapes:
        for n in levels:
            name = f"{shape}-{n}"
            path = os.path.join(args.out, f"run-{name}.h5")
            if not os.path.exists(path):
                run([f"{args.bin}/dda-run", "-c", os.path.join(REPO, "samples/bench-slope/scene.yaml"),
                     "--set", f"terrain={terrain}", "--set", f"block_file={blocks}", "--set", f"blocks=[{name}]",
                     "--set", f"realizations={args.realizations}", "--threads", str(args.threads), "-q"] + extra +
                    ["-o", path], log)
            with h5py.File(path) as f:
                r = f["records"]
                data[name] = {k: r[k][()] for k in ["end_reason", "runout", "lateral", "max_speed", "max_jump_height",
                                                    "impacts", "final_position"]}
    md = []
    for shape in args.shapes:
        md.append(f"\n**{shape}**\n")
        md.append("| faces | rest / left / time limit / failed | past the toe | runout P50 (m) | max speed P50 (m/s) | jump P50 (m) | impacts |")
        md.append("|---:|---|---:|---:|---:|---:|---:|")
        for n in levels:
            d = data[f"{shape}-{n}"]
            e = d["end_reason"]
            rest = e == 1
            if n in compared and (e >= 3).any():
                problems.append(f"{shape}-{n}: {int((e >= 3).sum())} realizations failed or met the time limit")
            md.append("| {} | {} / {} / {} / {} | {:.3f} | {:.1f} | {:.2f} | {:.2f} | {:.1f} |".format(
                faces[f"{shape}-{n}"], int(rest.sum()), int((e == 2).sum()), int((e == 3).sum()), int((e >= 4).sum()),
                float((d["final_position"][:, 0] >= TOE).mean()),
                float(np.median(d["runout"][rest])) if rest.any() else float("nan"),
                float(np.median(d["max_speed"])), float(np.median(d["max_jump_height"])), float(d["impacts"].mean())))
        md.append("\n| levels | KS runout | KS lateral | KS max speed | KS jump | KS final x | critical (all / at rest) |")
        md.append("|---|---:|---:|---:|---:|---:|---:|")
        for i in range(len(compared)):
            for j in range(i + 1, len(compared)):
                a, b = data[f"{shape}-{compared[i]}"], data[f"{shape}-{compared[j]}"]
                ra, rb = a["end_reason"] == 1, b["end_reason"] == 1
                n1, n2 = len(a["end_reason"]), len(b["end_reason"])
                m1, m2 = max(int(ra.sum()), 1), max(int(rb.sum()), 1)
                crit_all = 1.358 * math.sqrt((n1 + n2) / (n1 * n2))
                crit_rest = 1.358 * math.sqrt((m1 + m2) / (m1 * m2))
                measured = {"runout": (ks(a["runout"][ra], b["runout"][rb]), crit_rest),
                            "lateral": (ks(a["lateral"][ra], b["lateral"][rb]), crit_rest),
                            "max speed": (ks(a["max_speed"], b["max_speed"]), crit_all),
                            "jump": (ks(a["max_jump_height"], b["max_jump_height"]), crit_all),
                            "final x": (ks(a["final_position"][:, 0], b["final_position"][:, 0]), crit_all)}
                pair = f"{shape} {faces[f'{shape}-{compared[i]}']} / {faces[f'{shape}-{compared[j]}']} faces"
                for what, (distance, critical) in measured.items():
                    if not distance <= critical:
                        problems.append(f"{pair}: KS {what} {distance:.3f} above the critical {critical:.3f}")
                p1 = float((a["final_position"][:, 0] >= TOE).mean())
                p2 = float((b["final_position"][:, 0] >= TOE).mean())
                pooled = (p1 * n1 + p2 * n2) / (n1 + n2)
                allowed = 1.96 * math.sqrt(pooled * (1.0 - pooled) * (1.0 / n1 + 1.0 / n2))
                if abs(p1 - p2) > allowed:
                    problems.append(f"{pair}: shares past the toe {p1:.3f} and {p2:.3f} differ by more than {allowed:.3f}")
                md.append("| {} / {} | {:.3f} | {:.3f} | {:.3f} | {:.3f} | {:.3f} | {:.3f} / {:.3f} |".format(
                    faces[f"{shape}-{compared[i]}"], faces[f"{shape}-{compared[j]}"],
                    *(v[0] for v in measured.values()), crit_all, crit_rest))
    text = "\n".join(md) + "\n"
    with open(os.path.join(args.out, "convergence.md"), "w") as f:
        f.write(text)
    print(text)
    if args.check:
        for p in problems:
            print(f"mesh_convergence.py: {p}", file=sys.stderr)
        if problems:
            sys.exit(1)
        print(f"mesh_convergence.py: the levels {', '.join(map(str, compared))} agree")


if __name__ == "__main__":
    main()
