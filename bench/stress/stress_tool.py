#!/usr/bin/python3
"""Helpers of the numerical stress suite (bench/stress/stress.sh).

Sub-commands:
  rock-obj OUT [--seed S]              noisy, dented (non-convex) closed rock mesh, OBJ
  sphere-obj OUT [--levels N]          icosphere of 20*4^N triangles (sphere-like block), OBJ
  tin-plane-obj OUT --angle DEG ...    a plane as a TIN of irregular triangles, OBJ
  dem-spikes OUT ...                   a planar slope DEM with random cells raised 1-3 m, ESRI ASCII
  dem-steps OUT ...                    a terraced DEM with 1-2 m near-vertical steps, ESRI ASCII
  orient KIND ...                      z-y-x Euler angles [yaw, pitch, roll] (deg) of a fixed release
  report CASES_DIR [--markdown]        read the run files, print the tables, set the exit status

Only the standard library, numpy and h5py (Debian python3-numpy, python3-h5py) are used.
Every random draw comes from numpy's PCG64 seeded explicitly, so the inputs are the same
on every run.
"""

import argparse
import json
import math
import os
import re
import sys

import numpy as np

# dda-run's records/end_reason codes (docs/formats.md, "Run file").
END_REASONS = ["rest", "left_terrain", "step_limit", "non_finite", "no_convergence", "penetration"]
FAILURE_REASONS = {"non_finite", "no_convergence", "penetration"}
# Per-realization diagnostics the engine may write; shown when the run file has them.
OPTIONAL_COLUMNS = [("invariant_violations", "sum"), ("max_energy_gain", "max"), ("max_overlap", "max"), ("energy_removed", "sum"),
                    ("limiter_share", "max")]
# A realization from which the energy limiter takes more than this share of its peak kinetic
# energy fails: the limiter is for round-off, the step control redoes steps that gain more
# (docs/dda.md, Step control).
LIMITER_SHARE = 0.02


# ----------------------------------------------------------------------------- geometry

def rot_x(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]], dtype=float)


def rot_y(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]], dtype=float)


def rot_z(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]], dtype=float)


def euler_zyx_deg(r):
    """[yaw, pitch, roll] in degrees with r = Rz(yaw) Ry(pitch) Rx(roll), dda-run's
    release.orientation_deg convention (libs/mc/src/realization.cpp)."""
    pitch = math.asin(max(-1.0, min(1.0, -r[2, 0])))
    yaw = math.atan2(r[1, 0], r[0, 0])
    roll = math.atan2(r[2, 1], r[2, 2])
    return [math.degrees(yaw), math.degrees(pitch), math.degrees(roll)]


def rotation_taking(a, b):
    """The smallest rotation taking unit vector a to unit vector b."""
    a = a / np.linalg.norm(a)
    b = b / np.linalg.norm(b)
    v = np.cross(a, b)
    c = float(a @ b)
    if c < -1.0 + 1e-12:
        # Opposite: half a turn about any axis normal to a.
        axis = np.cross(a, [1.0, 0.0, 0.0])
        if np.linalg.norm(axis) < 1e-6:
            axis = np.cross(a, [0.0, 1.0, 0.0])
        axis /= np.linalg.norm(axis)
        return 2.0 * np.outer(axis, axis) - np.eye(3)
    k = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + k + k @ k / (1.0 + c)


def slope_normal(angle_deg):
    """Upward unit normal of terrain-gen's synthetic plane z = (length - x) tan(angle)."""
    t = math.radians(angle_deg)
    return np.array([math.sin(t), 0.0, math.cos(t)])


def write_obj(path, vertices, faces):
    with open(path, "w") as f:
        f.write("# written by bench/stress/stress_tool.py\n")
        for v in vertices:
            f.write("v %.17g %.17g %.17g\n" % tuple(v))
        for t in faces:
            f.write("f %d %d %d\n" % (t[0] + 1, t[1] + 1, t[2] + 1))


def icosphere(levels):
    p = (1.0 + math.sqrt(5.0)) / 2.0
    verts = [(-1, p, 0), (1, p, 0), (-1, -p, 0), (1, -p, 0), (0, -1, p), (0, 1, p),
             (0, -1, -p), (0, 1, -p), (p, 0, -1), (p, 0, 1), (-p, 0, -1), (-p, 0, 1)]
    verts = [np.array(v, dtype=float) / np.linalg.norm(v) for v in verts]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
             (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
             (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(levels):
        cache = {}

        def mid(i, j):
            key = (min(i, j), max(i, j))
            if key not in cache:
                m = verts[i] + verts[j]
                verts.append(m / np.linalg.norm(m))
                cache[key] = len(verts) - 1
            return cache[key]

        new = []
        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            new += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = new
    return np.array(verts), np.array(faces)


def mesh_volume(v, f):
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def cmd_rock_obj(args):
    """A scanned-like rock: a level-3 icosphere (1280 triangles; --levels 4: 5120) stretched to 1.4 x 1 x 0.75,
    its radius modulated by smooth random bumps, per-vertex noise and one deep dent. The
    surface stays a radial graph over the sphere (star-shaped about the centre), so it is
    closed and cannot self-intersect, whatever the noise."""
    rng = np.random.default_rng(args.seed)
    v, f = icosphere(args.levels)
    r = np.ones(len(v))
    for _ in range(25):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        width = rng.uniform(0.3, 0.8)
        ang = np.arccos(np.clip(v @ d, -1.0, 1.0))
        r += rng.normal(0.0, 0.08) * np.exp(-(ang / width) ** 2)
    r += rng.uniform(-0.02, 0.02, size=len(v))
    dent = np.array([0.3, -0.5, 0.8])
    dent /= np.linalg.norm(dent)
    ang = np.arccos(np.clip(v @ dent, -1.0, 1.0))
    r *= 1.0 - 0.4 * np.exp(-(ang / 0.45) ** 2)
    if r.min() <= 0.2:
        sys.exit("rock-obj: radius collapsed; pick another seed")
    pts = v * r[:, None] * np.array([1.4, 1.0, 0.75])
    pts *= (args.volume / mesh_volume(pts, f)) ** (1.0 / 3.0)
    write_obj(args.out, pts, f)


def cmd_sphere_obj(args):
    """A sphere-like block: an icosphere of 20 * 4^levels triangles (1280 at level 3)
    scaled to the given volume."""
    v, f = icosphere(args.levels)
    v = v * (args.volume / mesh_volume(v, f)) ** (1.0 / 3.0)
    write_obj(args.out, v, f)


def cmd_tin_plane_obj(args):
    """A plane z = (length - x) tan(angle) as irregular triangles: a jittered lattice (plan
    jitter up to `jitter` of a cell, border points kept on the border) cut along random
    diagonals. Every vertex lies on the plane to round-off."""
    rng = np.random.default_rng(args.seed)
    nx = int(round(args.length / args.cell)) + 1
    ny = int(round(args.width / args.cell)) + 1
    t = math.tan(math.radians(args.angle))
    verts = []
    for j in range(ny):
        for i in range(nx):
            x, y = i * args.cell, j * args.cell
            if 0 < i < nx - 1:
                x += rng.uniform(-args.jitter, args.jitter) * args.cell
            if 0 < j < ny - 1:
                y += rng.uniform(-args.jitter, args.jitter) * args.cell
            verts.append((x, y, (args.length - x) * t))
    faces = []
    for j in range(ny - 1):
        for i in range(nx - 1):
            p00, p10 = j * nx + i, j * nx + i + 1
            p01, p11 = (j + 1) * nx + i, (j + 1) * nx + i + 1
            if rng.uniform() < 0.5:
                faces += [(p00, p10, p11), (p00, p11, p01)]
            else:
                faces += [(p00, p10, p01), (p10, p11, p01)]
    write_obj(args.out, np.array(verts), np.array(faces))


def write_asc(path, z, cell):
    """ESRI ASCII grid; z[j][i] at plan (i*cell, j*cell) (cell centres), rows written
    north first."""
    ny, nx = z.shape
    with open(path, "w") as f:
        f.write("ncols %d\nnrows %d\nxllcenter 0\nyllcenter 0\ncellsize %.17g\nNODATA_value -9999\n" %
                (nx, ny, cell))
        for j in range(ny - 1, -1, -1):
            f.write(" ".join("%.17g" % val for val in z[j]) + "\n")


def cmd_dem_spikes(args):
    """A uniform slope with a fraction of its points raised by 1-3 m: one-cell spikes."""
    rng = np.random.default_rng(args.seed)
    nx = int(round(args.length / args.cell)) + 1
    ny = int(round(args.width / args.cell)) + 1
    x = np.arange(nx) * args.cell
    z = np.tile((args.length - x) * math.tan(math.radians(args.angle)), (ny, 1))
    spikes = rng.uniform(size=z.shape) < args.fraction
    z[spikes] += rng.uniform(1.0, 3.0, size=int(spikes.sum()))
    write_asc(args.out, z, args.cell)


def cmd_dem_steps(args):
    """Terraces: treads `tread` m long falling gently downslope, separated by steps of
    1-3 m drawn per step; each step drops within one cell (near-vertical at small cells)."""
    rng = np.random.default_rng(args.seed)
    nx = int(round(args.length / args.cell)) + 1
    ny = int(round(args.width / args.cell)) + 1
    x = np.arange(nx) * args.cell
    n_steps = int(args.length // args.tread)
    drops = rng.uniform(args.step_min, args.step_max, size=n_steps)
    tread_fall = math.tan(math.radians(args.tread_angle))
    k = np.minimum((x // args.tread).astype(int), n_steps - 1)
    below = np.concatenate([[0.0], np.cumsum(drops)])[k]
    z1 = drops.sum() + args.length * tread_fall - below - x * tread_fall
    write_asc(args.out, np.tile(z1, (ny, 1)), args.cell)


def cmd_orient(args):
    if args.kind == "slope-face":
        # Face-down, flat on the plane of inclination `angle` (dipping towards +x), turned
        # by `yaw` about the plane's normal: R = Ry(angle) Rz(yaw).
        r = rot_y(math.radians(args.angle)) @ rot_z(math.radians(args.yaw))
    else:
        import h5py
        with h5py.File(args.block_file, "r") as f:
            g = None
            for name in f["blocks"]:
                if f["blocks"][name].attrs["name"] == args.block:
                    g = f["blocks"][name]
            if g is None:
                sys.exit("orient: no block '%s' in %s" % (args.block, args.block_file))
            v = g["vertices"][:]
            off = g["face_offsets"][:]
            fv = g["face_vertices"][:]
        if args.kind == "vertex":
            feature = v[0]
        else:
            # Midpoint of the first edge of face 0: an edge of the block's hull.
            feature = 0.5 * (v[fv[off[0]]] + v[fv[off[0] + 1]])
        # Point the feature against the ground's normal, so it is what touches first,
        # then turn about that normal by `yaw`.
        n = slope_normal(args.angle)
        r = rotation_taking(feature, -n)
        r = rotation_taking(np.array([0.0, 0.0, 1.0]), n) @ rot_z(math.radians(args.yaw)) @ \
            rotation_taking(np.array([0.0, 0.0, 1.0]), n).T @ r
    print("[%s]" % ", ".join("%.12g" % a for a in euler_zyx_deg(r)))


# ----------------------------------------------------------------------------- report

def read_run(path):
    import h5py
    with h5py.File(path, "r") as f:
        rec = f["records"]
        out = {k: rec[k][:] for k in rec.keys()}
        if "trajectories" in f:
            tr = f["trajectories"]
            out["_traj"] = {k: tr[k][:] for k in ("realization", "time", "position", "energy") if k in tr}
        # The gravity the run used, from its effective settings (docs/formats.md, provenance).
        settings = f["provenance"].attrs.get("settings_yaml", "") if "provenance" in f else ""
        if isinstance(settings, bytes):
            settings = settings.decode()
        m = re.search(r"^\s*gravity:\s*([-+0-9.eE]+)", settings, re.MULTILINE)
        out["_gravity"] = float(m.group(1)) if m else None
    return out


def analytic_slide(meta, run):
    """Distance travelled along the slope against g (sin t - mu cos t) T^2 / 2, T the
    simulated time the record reports (the step limit makes it 1 s unless steps were cut).
    Distance = (final - release) . downslope unit vector; also runout / cos t. A rolling
    case (meta "rolling": the share of g sin t a rolling body gets, 5/7 for a sphere,
    and mu 0: friction does no work on a body that rolls) against rolling g sin t T^2 / 2."""
    theta = math.radians(float(meta["angle"]))
    mu = float(meta["mu"])
    rolling = float(meta.get("rolling", 1.0))
    g = run["_gravity"]
    if g is None:
        sys.exit("report: %s: no engine gravity in the run file's settings" % meta.get("case", "analytic case"))
    down = np.array([math.cos(theta), 0.0, -math.sin(theta)])
    rows = []
    for k in range(len(run["end_reason"])):
        t = float(run["time"][k])
        d = (run["final_position"][k] - run["release_position"][k]) @ down
        from_runout = float(run["runout"][k]) / math.cos(theta)
        expected = 0.5 * g * (rolling * math.sin(theta) - mu * math.cos(theta)) * t * t
        rows.append({
            "realization": int(run["realization"][k]),
            "end": END_REASONS[int(run["end_reason"][k]) - 1] if 1 <= run["end_reason"][k] <= 6 else "?",
            "time": t, "measured": d, "from_runout": from_runout, "expected": expected,
            "rel_error": abs(d - expected) / expected if expected > 0 else float("nan"),
            "lateral": float(run["lateral"][k]),
        })
    return rows


def analytic_stick(meta, run):
    """Drift of the resting block: the largest distance between the centroid at the end and
    its sampled positions over the last `window` seconds (trajectory samples), i.e. how far
    it moved once it should have been still."""
    window = float(meta["window"])
    rows = []
    traj = run.get("_traj")

    def moved_within(i, k, seconds):
        # Largest distance from the final centroid of the samples of the last `seconds`.
        if traj is None or not len(traj.get("time", [])):
            return float("nan"), 0
        sel = (traj["realization"] == i) & (traj["time"] >= float(run["time"][k]) - seconds)
        if not sel.any():
            return float("nan"), 0
        d = np.linalg.norm(traj["position"][sel] - run["final_position"][k], axis=1)
        return float(d.max()), int(sel.sum())

    for k in range(len(run["end_reason"])):
        i = int(run["realization"][k])
        drift, samples = moved_within(i, k, window)
        rows.append({
            "realization": i,
            "end": END_REASONS[int(run["end_reason"][k]) - 1] if 1 <= run["end_reason"][k] <= 6 else "?",
            "time": float(run["time"][k]), "drift": drift, "samples": samples,
            "last_second": moved_within(i, k, 1.0)[0],
            "travel": float(np.linalg.norm(run["final_position"][k] - run["release_position"][k])),
        })
    return rows


def analytic_facet(meta, run):
    """Share of the kinetic energy each facet impact of a tumbling block takes, from the
    mechanical energy E (kinetic + potential) sampled along the trajectory: between facet
    impacts a block pivoting on an edge keeps E (gravity only), so each run of samples in
    which E falls by more than 1e-4 of the kinetic energy is one impact, and E lost over
    it divided by the kinetic energy before it is its loss share. Impacts in the first
    0.3 s (the launch) and below 500 J of kinetic energy (the block coming to rest) are
    left out. Kinetic energy = E - m g z, m from the record's mass column when there is
    one, else 2800 kg/m^3 x 1 m^3."""
    rows = []
    traj = run.get("_traj")
    g = run["_gravity"] or 9.81
    for k in range(len(run["end_reason"])):
        i = int(run["realization"][k])
        shares = []
        if traj is not None and "energy" in traj:
            sel = traj["realization"] == i
            t, e, z = traj["time"][sel], traj["energy"][sel], traj["position"][sel][:, 2]
            mass = float(run["mass"][k]) if "mass" in run else 2800.0
            ke = e - mass * g * z
            de = np.diff(e)
            drop = de < -1e-4 * np.maximum(ke[1:], 1.0)
            j, n = 0, len(de)
            while j < n:
                if not drop[j]:
                    j += 1
                    continue
                a = j
                while j + 1 < n and (drop[j + 1] or (j + 2 < n and drop[j + 2])):
                    j += 1
                b = j + 1
                if t[a] > 0.3 and ke[a] > 500.0:
                    shares.append(float((e[a] - e[b]) / ke[a]))
                j = b
        med = float(np.median(shares)) if shares else float("nan")
        rows.append({
            "realization": i,
            "end": END_REASONS[int(run["end_reason"][k]) - 1] if 1 <= run["end_reason"][k] <= 6 else "?",
            "time": float(run["time"][k]), "impacts": len(shares), "median": med, "shares": shares,
            "deviation": abs(med - float(meta["plastic_pivot_loss"])) if shares else float("nan"),
        })
    return rows


def fmt_g(x, digits=3):
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    return "%.*g" % (digits, x)


def load_cases(directory):
    """One case per DIR/ID.json (queued by stress.sh), with ID.rc (dda-run's exit status),
    ID.seconds (wall time) and ID.log (its messages) once it ran."""
    cases = []
    for entry in sorted(os.listdir(directory)):
        if not entry.endswith(".json"):
            continue
        base = os.path.join(directory, entry[:-5])
        with open(base + ".json") as f:
            c = json.load(f)
        c["exit_code"] = int(open(base + ".rc").read()) if os.path.exists(base + ".rc") else None
        c["seconds"] = float(open(base + ".seconds").read()) if os.path.exists(base + ".seconds") else None
        c["error"] = ""
        if os.path.exists(base + ".log"):
            # dda-run's one-line error, without the tool and scene file prefix.
            errors = [l.strip() for l in open(base + ".log") if "error:" in l]
            c["error"] = errors[-1].split(".yaml: ", 1)[-1] if errors else ""
        cases.append(c)
    return cases


def evaluate(c):
    """Counts by end reason, failures and the optional diagnostics of one case."""
    res = {"case": c, "counts": {r: 0 for r in END_REASONS}, "records": 0, "failures": 0,
           "optional": {}, "status": "ok", "note": ""}
    rc = c.get("exit_code")
    if rc is None or not os.path.exists(c["run"]):
        res["status"] = "ERROR"
        res["note"] = "no run file; dda-run exit %s%s" % (rc, ": " + c["error"] if c["error"] else "")
        return res
    run = read_run(c["run"])
    codes = np.asarray(run["end_reason"], dtype=int)
    n = len(codes)
    res["records"] = n
    for code in codes:
        if 1 <= code <= len(END_REASONS):
            res["counts"][END_REASONS[code - 1]] += 1
        else:
            res["status"] = "ERROR"
            res["note"] = "unknown end reason %d" % code
    failed = np.isin(codes, [END_REASONS.index(r) + 1 for r in FAILURE_REASONS])
    for col, how in OPTIONAL_COLUMNS:
        if col in run:
            vals = np.asarray(run[col], dtype=float)
            res["optional"][col] = (float(vals.sum() if how == "sum" else vals.max()) if n else 0.0)
            if col == "invariant_violations":
                failed |= vals > 0
    if "energy_removed" in run and "max_kinetic_energy" in run:
        removed = np.asarray(run["energy_removed"], dtype=float)
        peak = np.asarray(run["max_kinetic_energy"], dtype=float)
        share = removed / np.maximum(peak, np.finfo(float).tiny)
        res["optional"]["limiter_share"] = float(share.max()) if n else 0.0
        failed |= (removed > 0.0) & (share > LIMITER_SHARE)
    res["failures"] = int(failed.sum())
    # The first failing realization indices, to rerun them.
    res["failed_realizations"] = [int(i) for i in np.asarray(run["realization"])[failed][:4]]
    if rc != 0:
        res["status"] = "ERROR"
        res["note"] = "dda-run exit %d" % rc
    elif n != c["realizations"]:
        res["status"] = "ERROR"
        res["note"] = "%d records for %d realizations" % (n, c["realizations"])
    elif res["failures"]:
        res["status"] = "FAIL"
        res["note"] = "realizations " + ", ".join(map(str, res["failed_realizations"])) + \
            (" …" if res["failures"] > len(res["failed_realizations"]) else "")
    meta = c.get("analytic")
    if meta:
        res["analytic"] = {"slide": analytic_slide, "stick": analytic_stick, "facet": analytic_facet}[meta["kind"]](meta, run)
    return res


class Table:
    """Plain text (aligned columns) or Markdown."""

    def __init__(self, markdown, lines):
        self.md = markdown
        self.lines = lines

    def __call__(self, header, rows, align):
        if self.md:
            self.lines.append("| " + " | ".join(header) + " |")
            self.lines.append("|" + "|".join("---:" if a == "r" else "---" for a in align) + "|")
            for r in rows:
                self.lines.append("| " + " | ".join(r) + " |")
        else:
            w = [max([len(h)] + [len(r[i]) for r in rows]) for i, h in enumerate(header)]

            def line(cells):
                return "  ".join(x.rjust(w[i]) if align[i] == "r" else x.ljust(w[i])
                                 for i, x in enumerate(cells)).rstrip()

            self.lines.append(line(header))
            self.lines.append("  ".join("-" * x for x in w))
            for r in rows:
                self.lines.append(line(r))
        self.lines.append("")


def combine(acc, col, v):
    how = dict(OPTIONAL_COLUMNS)[col]
    if col not in acc:
        acc[col] = v
    else:
        acc[col] = acc[col] + v if how == "sum" else max(acc[col], v)


def analytic_family(name):
    """Analytic cases grouped for the summary: the name without its yaw (and friction)."""
    return re.sub(r"-yaw[0-9.]+", "", name)


def cmd_report(args):
    results = [evaluate(c) for c in load_cases(args.cases)]
    opt_cols = [col for col, _ in OPTIONAL_COLUMNS if any(col in r["optional"] for r in results)]
    lines = []
    table = Table(args.markdown, lines)
    title = (lambda t: lines.extend([t, ""])) if args.markdown else (lambda t: lines.append(t))

    # Per case.
    rows = []
    for res in results:
        c = res["case"]
        cells = [c["group"], c["name"], "%d/%d" % (res["records"], c["realizations"])]
        cells += [str(res["counts"][r]) for r in END_REASONS]
        cells += [fmt_g(res["optional"].get(col)) for col in opt_cols]
        cells += [str(res["failures"]), fmt_g(c["seconds"]),
                  res["status"] + (" (" + res["note"] + ")" if res["note"] else "")]
        rows.append(cells)
    title("Per case (realizations: records in the run file / asked):")
    table(["group", "case", "realizations"] + END_REASONS + opt_cols + ["failures", "seconds", "status"], rows,
          ["l", "l"] + ["r"] * (1 + len(END_REASONS) + len(opt_cols) + 2) + ["l"])

    # Analytic cases, one row per realization; a case that did not run is one miss.
    misses = 0
    slide_rows, stick_rows, facet_rows = [], [], []
    families = {}
    for res in results:
        c = res["case"]
        meta = c.get("analytic")
        if not meta:
            continue
        fam = families.setdefault(analytic_family(c["name"]), {
            "kind": meta["kind"], "target": float(meta["target"]), "cases": 0, "realizations": 0, "ok": 0,
            "miss": 0, "not_run": 0, "values": [], "ends": {}})
        fam["cases"] += 1
        if res["status"] == "ERROR" and not res.get("analytic"):
            misses += 1
            fam["not_run"] += 1
            if meta["kind"] == "slide":
                slide_rows.append([c["name"], "-", "did not run"] + ["-"] * 6 + ["%g" % float(meta["target"]), "MISS"])
            elif meta["kind"] == "facet":
                facet_rows.append([c["name"], "-", "did not run"] + ["-"] * 4 + ["%g" % float(meta["target"]), "MISS"])
            else:
                stick_rows.append([c["name"], "-", "did not run"] + ["-"] * 4 + ["%g" % float(meta["target"]), "MISS"])
            continue
        target = float(meta["target"])
        for a in res.get("analytic", []):
            if meta["kind"] == "slide":
                ok = a["end"] == "step_limit" and a["rel_error"] <= target
                # runout / cos θ is the distance only for a start on the plane (no drop).
                rr = (abs(a["from_runout"] / a["expected"] - 1.0)
                      if a["expected"] > 0 and meta.get("from_rest") else float("nan"))
                slide_rows.append([c["name"], str(a["realization"]), a["end"], "%.6g" % a["time"],
                                   "%.9g" % a["measured"], "%.9g" % a["expected"], "%.2e" % a["rel_error"],
                                   "-" if math.isnan(rr) else "%.2e" % rr, "%.1e" % a["lateral"], "%g" % target,
                                   "ok" if ok else "MISS"])
                fam["values"].append(a["rel_error"])
            elif meta["kind"] == "facet":
                # One realization's median swings with how it hops and pivots (0.13-0.36 in
                # eight realizations of one case): the verdict is on the case's pooled median.
                facet_rows.append([c["name"], str(a["realization"]), a["end"], "%.6g" % a["time"], str(a["impacts"]),
                                   "%.3f" % a["median"] if a["impacts"] else "-",
                                   "%.3f" % float(meta["plastic_pivot_loss"]), "%g" % target, "-"])
                fam["realizations"] += 1
                fam["ends"][a["end"]] = fam["ends"].get(a["end"], 0) + 1
                continue
            else:
                ok = (a["end"] in ("step_limit", "rest") and not math.isnan(a["drift"]) and a["drift"] <= target)
                stick_rows.append([c["name"], str(a["realization"]), a["end"], "%.6g" % a["time"],
                                   "%.4g" % a["travel"], "%.2e" % a["drift"], "%.2e" % a["last_second"],
                                   "%g" % target, "ok" if ok else "MISS"])
                fam["values"].append(a["drift"])
            misses += not ok
            fam["realizations"] += 1
            fam["ok" if ok else "miss"] += 1
            fam["ends"][a["end"]] = fam["ends"].get(a["end"], 0) + 1
        if meta["kind"] == "facet":
            shares = [x for a in res.get("analytic", []) for x in a["shares"]]
            pooled = float(np.median(shares)) if shares else float("nan")
            deviation = abs(pooled - float(meta["plastic_pivot_loss"])) if shares else float("nan")
            ok = len(shares) >= 10 and deviation <= target
            facet_rows.append([c["name"], "all", "-", "-", str(len(shares)), "%.3f" % pooled if shares else "-",
                               "%.3f" % float(meta["plastic_pivot_loss"]), "%g" % target, "ok" if ok else "MISS"])
            misses += not ok
            fam["ok" if ok else "miss"] += 1
            fam["values"].append(deviation)
    if slide_rows:
        title("Analytic slide: distance along the slope after T s (the record's simulated time) against "
              "g (sin θ − μ cos θ) T²/2; also from runout / cos θ:")
        table(["case", "realization", "end", "T (s)", "distance (m)", "expected (m)", "rel. error",
               "rel. error (runout)", "lateral (m)", "target", "verdict"], slide_rows,
              ["l", "r", "l", "r", "r", "r", "r", "r", "r", "r", "l"])
    if stick_rows:
        title("Analytic stick: drift = largest distance of the centroid from its final position over the "
              "last 5 s of the run (trajectory samples), and over the last 1 s; moved = release to end:")
        table(["case", "realization", "end", "T (s)", "moved (m)", "drift (m)", "last 1 s (m)", "target",
               "verdict"], stick_rows, ["l", "r", "l", "r", "r", "r", "r", "r", "l"])

    if facet_rows:
        title("Analytic facet impacts: median share of the kinetic energy taken by a facet impact of the "
              "tumbling block, against the perfectly plastic pivot (target: the largest deviation of the "
              "median of all the case's impacts, row 'all'; ok/miss in the family table count cases):")
        table(["case", "realization", "end", "T (s)", "impacts", "median share", "plastic pivot", "target",
               "verdict"], facet_rows, ["l", "r", "l", "r", "r", "r", "r", "r", "l"])

    # The summary tables (those docs/benchmarks.md shows): per group, and the analytic
    # cases per family (all yaws together).
    groups = []
    for res in results:
        if res["case"]["group"] not in groups:
            groups.append(res["case"]["group"])
    rows = []
    for g in groups + [None]:
        sel = [r for r in results if g is None or r["case"]["group"] == g]
        counts = {r: sum(x["counts"][r] for x in sel) for r in END_REASONS}
        opt = {}
        for x in sel:
            for col, v in x["optional"].items():
                combine(opt, col, v)
        cells = [g if g else "total", str(len(sel)), str(sum(x["records"] for x in sel))]
        cells += [str(counts[r]) for r in END_REASONS]
        cells += [fmt_g(opt.get(col)) for col in opt_cols]
        cells += [str(sum(x["failures"] for x in sel)), str(sum(x["status"] == "ERROR" for x in sel))]
        rows.append(cells)
        if g is None:
            total = {"cases": len(sel), "records": sum(x["records"] for x in sel), "counts": counts, "opt": opt,
                     "failures": sum(x["failures"] for x in sel),
                     "errors": sum(x["status"] == "ERROR" for x in sel)}
    title("Per group:")
    table(["group", "cases", "realizations"] + END_REASONS + opt_cols + ["failures", "case errors"], rows,
          ["l"] + ["r"] * (2 + len(END_REASONS) + len(opt_cols) + 2))
    if families:
        rows = []
        for name, f in families.items():
            vals = [v for v in f["values"] if not math.isnan(v)]
            measure = {"slide": "rel. error", "stick": "drift (m)", "facet": "share deviation"}[f["kind"]]
            rows.append([name, str(f["cases"]), str(f["realizations"]),
                         ", ".join("%s %d" % kv for kv in sorted(f["ends"].items())) or "-",
                         str(f["ok"]), str(f["miss"]), str(f["not_run"]), measure,
                         "%.2e" % float(np.median(vals)) if vals else "-", "%.2e" % max(vals) if vals else "-",
                         "%g" % f["target"]])
        title("Analytic cases by family (every yaw together; 'not run': cases without a run file):")
        table(["family", "cases", "realizations", "ends", "ok", "miss", "not run", "measure", "median",
               "worst", "target"], rows, ["l", "r", "r", "l", "r", "r", "r", "l", "r", "r", "r"])

    summary = "total: %d cases, %d realizations: %s" % (
        total["cases"], total["records"], ", ".join("%s %d" % (r, total["counts"][r]) for r in END_REASONS))
    for col in opt_cols:
        summary += ", %s %s %s" % (col, dict(OPTIONAL_COLUMNS)[col], fmt_g(total["opt"].get(col)))
    summary += "; %d case errors, %d analytic misses; %d failures" % (total["errors"], misses, total["failures"])
    lines.append(summary)
    print("\n".join(lines))
    return 1 if (total["failures"] or total["errors"] or misses) else 0


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)

    s = sub.add_parser("rock-obj")
    s.add_argument("out")
    s.add_argument("--seed", type=int, default=5)
    s.add_argument("--levels", type=int, default=3)
    s.add_argument("--volume", type=float, default=1.0)

    s = sub.add_parser("sphere-obj")
    s.add_argument("out")
    s.add_argument("--levels", type=int, default=3)
    s.add_argument("--volume", type=float, default=1.0)

    s = sub.add_parser("tin-plane-obj")
    s.add_argument("out")
    s.add_argument("--angle", type=float, required=True)
    s.add_argument("--length", type=float, default=40.0)
    s.add_argument("--width", type=float, default=10.0)
    s.add_argument("--cell", type=float, default=1.0)
    s.add_argument("--jitter", type=float, default=0.3)
    s.add_argument("--seed", type=int, default=3)

    s = sub.add_parser("dem-spikes")
    s.add_argument("out")
    s.add_argument("--angle", type=float, default=35.0)
    s.add_argument("--length", type=float, default=60.0)
    s.add_argument("--width", type=float, default=30.0)
    s.add_argument("--cell", type=float, default=1.0)
    s.add_argument("--fraction", type=float, default=0.03)
    s.add_argument("--seed", type=int, default=7)

    s = sub.add_parser("dem-steps")
    s.add_argument("out")
    s.add_argument("--length", type=float, default=48.0)
    s.add_argument("--width", type=float, default=20.0)
    s.add_argument("--cell", type=float, default=0.25)
    s.add_argument("--tread", type=float, default=4.0)
    s.add_argument("--tread-angle", type=float, default=8.0)
    s.add_argument("--step-min", type=float, default=1.0)
    s.add_argument("--step-max", type=float, default=2.0)
    s.add_argument("--seed", type=int, default=9)

    s = sub.add_parser("orient")
    s.add_argument("kind", choices=["slope-face", "vertex", "edge"])
    s.add_argument("--angle", type=float, default=0.0, help="ground inclination (deg), dipping towards +x")
    s.add_argument("--yaw", type=float, default=0.0, help="turn about the ground normal (deg)")
    s.add_argument("--block-file")
    s.add_argument("--block")

    s = sub.add_parser("report")
    s.add_argument("cases", help="the cases/ directory stress.sh writes")
    s.add_argument("--markdown", action="store_true")

    args = p.parse_args()
    handlers = {"rock-obj": cmd_rock_obj, "sphere-obj": cmd_sphere_obj, "tin-plane-obj": cmd_tin_plane_obj, "dem-spikes": cmd_dem_spikes,
                "dem-steps": cmd_dem_steps, "orient": cmd_orient, "report": cmd_report}
    sys.exit(handlers[args.cmd](args) or 0)


if __name__ == "__main__":
    main()
