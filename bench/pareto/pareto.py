#!/usr/bin/python3
"""Run time against error: every setting that trades time for accuracy, measured on the
outputs users report.

  bench/pareto/pareto.py [--bin build/bin] [--out out/pareto] [--realizations N]
                         [--jobs J] [--part study,lod,analytic] [--quick]

Three parts, each against its own reference:

  study     the SPEC §6 reference study (bench slope S1-S3, blocks R1-R4, N realizations
            per level, seed 1), once per setting. Reference: time step 0.1 ms (the contact
            spring is relative, k = m (Omega/dt)^2, so it is 100 times stiffer than at the
            default 1 ms). Error of a setting: per level, the two-sample Kolmogorov-Smirnov
            distance of runout, |lateral|, max speed, jump height and toe-barrier energy
            to the reference's, P50/P95 shifts and the toe-fraction difference. The same
            study with another seed at the reference settings gives the sampling floor:
            a KS distance at that level is no evidence of an error.
  lod       a scanned-like concave rock (5120 triangles) simplified to 1280, 500, 100 and
            20 triangles and to its convex hull, on S2; reference: the 5120-triangle rock.
  analytic  SPEC §7 through dda-run: a 1 m^3 cube sliding 1 s on a 30 deg plane (mu = 0.2)
            from rest, against g (sin - mu cos) t^2 / 2, and sticking 10 s (mu = 0.6),
            across time step and contact Omega, both DOF paths.

Cost is the CPU time (user + system) of one single-threaded dda-run process divided by
its realizations (analytic: less the same process stopped after one step, its start-up);
two processes run at once (--jobs) on a 2-core machine. Runs are kept
in OUT (a rerun with the same settings reuses them). Writes OUT/results.json,
OUT/tables.md (Markdown, the tables of docs/benchmarks.md "Run time against error") and
OUT/pareto-study.png / .svg, OUT/pareto-analytic.png / .svg.
"""
import argparse
import concurrent.futures
import json
import math
import os
import platform
import shlex
import subprocess
import sys
import time

import h5py
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "bench", "dda"))
from compare_runs import ks  # noqa: E402

LEVELS = [("S1", 0.125), ("S2", 0.25), ("S3", 0.5)]
TOE_X = 36.0
FAILED = [4, 5, 6]
VARIABLES = ["runout", "lateral", "max_speed", "max_jump_height", "toe_energy"]

# (name, group, triangulation of the terrain, dda-run --set values). The first entry is
# the reference; "floor" is the reference with another seed.
STUDY = [
    ("reference", "reference", "alternating",
     ["engine.time_step=1e-4", "engine.rest_step_ratio=1", "engine.flight_step_ratio=1"]),
    ("floor", "sampling floor", "alternating",
     ["engine.time_step=1e-4", "engine.rest_step_ratio=1", "engine.flight_step_ratio=1", "seed=2"]),
    ("default", "defaults", "alternating", []),
    ("dt=2e-4", "time step", "alternating", ["engine.time_step=2e-4"]),
    ("dt=5e-4", "time step", "alternating", ["engine.time_step=5e-4"]),
    ("dt=2e-3", "time step", "alternating", ["engine.time_step=2e-3"]),
    ("dt=4e-3", "time step", "alternating", ["engine.time_step=4e-3"]),
    ("omega=5", "contact stiffness", "alternating", ["engine.penalty_omega=5"]),
    ("omega=10", "contact stiffness", "alternating", ["engine.penalty_omega=10"]),
    ("omega=50", "contact stiffness", "alternating", ["engine.penalty_omega=50"]),
    ("omega=100", "contact stiffness", "alternating", ["engine.penalty_omega=100"]),
    ("k=1e11 N/m", "contact stiffness", "alternating", ["engine.penalty_stiffness=1e11"]),
    ("oc=2", "open-close iterations", "alternating", ["engine.max_open_close_iterations=2"]),
    ("oc=4", "open-close iterations", "alternating", ["engine.max_open_close_iterations=4"]),
    ("oc=16", "open-close iterations", "alternating", ["engine.max_open_close_iterations=16"]),
    ("disp=0.005", "step control", "alternating", ["engine.max_displacement_ratio=0.005"]),
    ("disp=0.05", "step control", "alternating", ["engine.max_displacement_ratio=0.05"]),
    # The step control's other cut: a contact step that gains energy is redone shorter.
    ("energy cuts off", "step control", "alternating", ["engine.max_step_energy_gain=0"]),
    ("energy gain x10", "step control", "alternating", ["engine.max_step_energy_gain=X10"]),
    ("full12", "DOF path", "alternating", ["engine.dof=full12"]),
    ("tri=fixed", "triangulation", "fixed", []),
    ("tri=random", "triangulation", "random", []),
    # The grid's points through terrain-gen's TIN path (CGAL's Delaunay triangulation):
    # every cell of a regular grid is cocircular, and CGAL's symbolic perturbation cuts
    # them all along the same diagonal.
    ("tri=delaunay", "triangulation", "delaunay", []),
    # What a skip saves (docs/dda.md, What is skipped when): the flight test off makes
    # every step a contact step; sampled trajectories are stored only when asked.
    ("flight test off", "skips", "alternating", ["engine.flight_test=false"]),
    ("trajectories 10 ms", "skips", "alternating", ["engine.trajectory_interval=0.01"]),
    ("rest x10", "rest rule", "alternating", ["engine.rest_kinetic_energy=X10"]),
    ("rest x0.1", "rest rule", "alternating", ["engine.rest_kinetic_energy=X0.1"]),
    ("dwell x0.25", "rest rule", "alternating", ["engine.rest_dwell=X0.25"]),
    ("dwell x4", "rest rule", "alternating", ["engine.rest_dwell=X4"]),
    # Settling blocks' longer steps (docs/dda.md, Step control): none, and twice the default.
    ("rest steps x1", "rest rule", "alternating", ["engine.rest_step_ratio=1"]),
    ("rest steps x8", "rest rule", "alternating", ["engine.rest_step_ratio=8"]),
    # Flight steps of up to this many nominal ones while the block is proven clear.
    ("flight steps x1", "flight steps", "alternating", ["engine.flight_step_ratio=1"]),
    ("flight steps x64", "flight steps", "alternating", ["engine.flight_step_ratio=64"]),
    # Slow blocks' longer steps: a rigid block outside an impact whose kinetic energy per
    # unit mass is below the threshold (J/kg; 0.02 ~ 0.2 m/s, 0.125 ~ 0.5 m/s, 0.5 ~ 1 m/s)
    # grows its contact steps like a settling one.
    ("slow=0.02", "slow steps", "alternating", ["engine.slow_kinetic_energy=0.02"]),
    ("slow=0.125", "slow steps", "alternating", ["engine.slow_kinetic_energy=0.125"]),
    ("slow=0.5", "slow steps", "alternating", ["engine.slow_kinetic_energy=0.5"]),
    ("impact x0.5", "impact threshold", "alternating", ["engine.impact_min_normal_speed=X0.5"]),
    ("impact x2", "impact threshold", "alternating", ["engine.impact_min_normal_speed=X2"]),
]
LOD = [("5120", 0), ("1280", 1280), ("500", 500), ("100", 100), ("20", 20), ("hull", -1)]
ANALYTIC_DT = [2e-4, 5e-4, 1e-3, 2e-3, 4e-3]
ANALYTIC_OMEGA = [5, 20, 80]


def log(msg):
    print("pareto: " + msg, file=sys.stderr, flush=True)


class Runner:
    def __init__(self, args):
        self.bin = os.path.abspath(args.bin)
        self.out = os.path.abspath(args.out)
        self.inputs = os.path.join(self.out, "inputs")
        os.makedirs(self.inputs, exist_ok=True)
        self.jobs = args.jobs
        self.defaults = self.engine_defaults()

    def tool(self, name, *argv, quiet=True):
        cmd = [os.path.join(self.bin, name)] + [str(a) for a in argv]
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0:
            sys.exit("pareto: failed: %s\n%s" % (" ".join(shlex.quote(c) for c in cmd), r.stderr))
        return r.stdout

    def engine_defaults(self):
        text = self.tool("dda-run", "--print-config")
        out, section = {}, None
        for line in text.splitlines():
            if line and not line.startswith(" ") and line.endswith(":"):
                section = line[:-1]
            elif section == "engine" and line.startswith("  ") and ":" in line:
                key, value = line.strip().split(":", 1)
                value = value.split("#", 1)[0].strip()
                try:
                    out[key] = float(value)
                except ValueError:
                    out[key] = value
        return out

    def expand(self, sets):
        """engine.KEY=Xf means f times the default."""
        out = []
        for s in sets:
            key, value = s.split("=", 1)
            if value.startswith("X"):
                value = "%.17g" % (float(value[1:]) * self.defaults[key.split(".", 1)[1]])
            out.append(key + "=" + value)
        return out

    def dda_run(self, scene, sets, run):
        """Runs dda-run once (single thread) unless RUN exists with the same arguments;
        returns the CPU seconds of the process."""
        argv = [os.path.join(self.bin, "dda-run"), "-c", scene, "--threads", "1", "-o", run]
        for s in sets:
            argv += ["--set", s]
        meta_path = run + ".json"
        if os.path.exists(run) and os.path.exists(meta_path):
            meta = json.load(open(meta_path))
            if meta.get("argv") == argv:
                return meta["cpu"]
        if os.path.exists(run):
            os.remove(run)
        start = time.time()
        proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        _, status, usage = os.wait4(proc.pid, 0)
        err = proc.stderr.read()
        rc = os.waitstatus_to_exitcode(status)
        if rc != 0:
            sys.exit("pareto: dda-run failed (%d): %s\n%s" % (rc, " ".join(argv), err))
        cpu = usage.ru_utime + usage.ru_stime
        json.dump({"argv": argv, "cpu": cpu, "wall": time.time() - start}, open(meta_path, "w"))
        return cpu

    def parallel(self, tasks):
        with concurrent.futures.ThreadPoolExecutor(self.jobs) as pool:
            futures = [pool.submit(t) for t in tasks]
            return [f.result() for f in futures]


# --- reading run files -------------------------------------------------------------


def read_run(path):
    with h5py.File(path, "r") as f:
        r = f["records"]
        out = {k: r[k][:] for k in ("end_reason", "runout", "lateral", "max_speed", "max_jump_height",
                                    "final_position", "realization")}
        names = [x.decode() if isinstance(x, bytes) else str(x) for x in f["run/barriers"][:]]
        c = f["crossings"]
        toe = names.index("toe") if "toe" in names else -1
        sel = c["barrier"][:] == toe
        # First crossing of the toe barrier per realization.
        energy = {}
        for rz, e in zip(c["realization"][:][sel], c["kinetic_energy"][:][sel]):
            energy.setdefault(int(rz), float(e))
        out["toe_energy"] = np.array(list(energy.values()))
    return out


def samples(run):
    end = run["end_reason"]
    rest = end == 1
    ok = ~np.isin(end, FAILED)
    return {
        "runout": run["runout"][rest], "lateral": np.abs(run["lateral"][rest]),
        "max_speed": run["max_speed"][ok], "max_jump_height": run["max_jump_height"][ok],
        "toe_energy": run["toe_energy"],
        "toe": float(np.mean(run["final_position"][:, 0] >= TOE_X)),
        "failures": int(np.isin(end, FAILED).sum()),
    }


def q(x, p):
    return float(np.percentile(x, p)) if len(x) else float("nan")


def compare(ref, other):
    """Worst KS distance over the variables, and per variable KS and relative P50/P95 shifts."""
    out = {"vars": {}}
    for v in VARIABLES:
        a, b = ref[v], other[v]
        out["vars"][v] = {"ks": ks(a, b), "p50": q(b, 50) / q(a, 50) - 1.0 if q(a, 50) else float("nan"),
                          "p95": q(b, 95) / q(a, 95) - 1.0 if q(a, 95) else float("nan")}
    out["ks_max"] = max(x["ks"] for x in out["vars"].values())
    out["toe_pp"] = 100.0 * (other["toe"] - ref["toe"])
    return out


# --- parts ----------------------------------------------------------------------------


def study_inputs(runner):
    grids = sorted({s[2] for s in STUDY} - {"delaunay"} | {"alternating"})
    for tri in grids:
        for name, index in LEVELS:
            path = os.path.join(runner.inputs, "terrain-%s-%s.h5" % (name, tri))
            if not os.path.exists(path):
                runner.tool("terrain-gen", "-c", os.path.join(ROOT, "samples/bench-slope/terrain.yaml"), "--set",
                            "roughness.roughness_index=%g" % index, "--set", "triangulation=" + tri, "-o", path)
    for name, _ in LEVELS:
        # The same points and roughness sigma as a surveyed point cloud (x y z per line).
        path = os.path.join(runner.inputs, "terrain-%s-delaunay.h5" % name)
        if os.path.exists(path):
            continue
        with h5py.File(os.path.join(runner.inputs, "terrain-%s-alternating.h5" % name), "r") as f:
            points, sigma = f["trn/vertices"][:], float(f["roughness"].attrs["sigma"])
        cloud = os.path.join(runner.inputs, "points-%s.xyz" % name)
        np.savetxt(cloud, points, fmt="%.9g")
        runner.tool("terrain-gen", cloud, "-c", os.path.join(ROOT, "samples/bench-slope/terrain.yaml"), "--set",
                    "roughness.sigma=%.17g" % sigma, "--set", "roughness.roughness_index=~", "-o", path)
    path = os.path.join(runner.inputs, "platonic.h5")
    if not os.path.exists(path):
        runner.tool("block-gen", "-c", os.path.join(ROOT, "samples/blocks/platonic.yaml"), "-o", path)


def part_study(runner, n, variants):
    study_inputs(runner)
    scene = os.path.join(ROOT, "samples/bench-slope/scene.yaml")
    tasks, keys = [], []
    for name, group, tri, sets in variants:
        for level, _ in LEVELS:
            run = os.path.join(runner.out, "study", "%s-%s.h5" % (name.replace(" ", "_").replace("/", "_"), level))
            os.makedirs(os.path.dirname(run), exist_ok=True)
            full = ["terrain=" + os.path.join(runner.inputs, "terrain-%s-%s.h5" % (level, tri)),
                    "block_file=" + os.path.join(runner.inputs, "platonic.h5"), "realizations=%d" % n,
                    "outputs.hazard_cell_size=0"] + runner.expand(sets)
            tasks.append(lambda run=run, full=full: runner.dda_run(scene, full, run))
            keys.append((name, level, run))
    log("study: %d runs of %d realizations" % (len(tasks), n))
    cpus = runner.parallel(tasks)
    per = {}
    for (name, level, run), cpu in zip(keys, cpus):
        per.setdefault(name, {})[level] = {"run": run, "cpu": cpu, "s": samples(read_run(run))}
    ref = per["reference"]
    default = per.get("default")
    rows = []
    for name, group, tri, sets in variants:
        levels = {}
        for level, _ in LEVELS:
            c = compare(ref[level]["s"], per[name][level]["s"])
            c["failures"] = per[name][level]["s"]["failures"]
            c["toe"] = per[name][level]["s"]["toe"]
            # Against the defaults too: how far a setting moves the study from what a
            # default run reports (the thresholds' sensitivity, docs/dda.md).
            c["toe_pp_vs_default"] = (100.0 * (c["toe"] - default[level]["s"]["toe"]) if default else float("nan"))
            levels[level] = c
        cpu = sum(per[name][lv]["cpu"] for lv, _ in LEVELS)
        rows.append({"name": name, "group": group, "sets": runner.expand(sets), "triangulation": tri,
                     "ms_per_realization": 1e3 * cpu / (n * len(LEVELS)), "levels": levels,
                     "ks_max": max(levels[lv]["ks_max"] for lv, _ in LEVELS),
                     "toe_pp_max": max(abs(levels[lv]["toe_pp"]) for lv, _ in LEVELS),
                     "toe_pp_vs_default_max": max(abs(levels[lv]["toe_pp_vs_default"]) for lv, _ in LEVELS),
                     "failures": sum(levels[lv]["failures"] for lv, _ in LEVELS)})
    return rows


def part_lod(runner, n):
    rock = os.path.join(runner.inputs, "rock5120.obj")
    if not os.path.exists(rock):
        subprocess.run([sys.executable, os.path.join(ROOT, "bench/stress/stress_tool.py"), "rock-obj", rock,
                        "--levels", "4"], check=True)
    lib = os.path.join(runner.inputs, "rocks.yaml")
    with open(lib, "w") as f:
        f.write("blocks:\n")
        for name, faces in LOD:
            simplify = ("{mode: hull}" if faces < 0 else "{mode: none}" if faces == 0
                        else "{mode: faces, target_faces: %d}" % faces)
            f.write("  - {name: rock-%s, mesh: %s, volume: 1, input: {simplify: %s}}\n" % (name, rock, simplify))
    blocks = os.path.join(runner.inputs, "rocks.h5")
    if not os.path.exists(blocks):
        runner.tool("block-gen", "-c", lib, "-o", blocks)
    study_inputs(runner)
    scene = os.path.join(ROOT, "samples/bench-slope/scene.yaml")
    tasks, keys = [], []
    for name, _ in LOD:
        run = os.path.join(runner.out, "lod", "rock-%s.h5" % name)
        os.makedirs(os.path.dirname(run), exist_ok=True)
        sets = ["terrain=" + os.path.join(runner.inputs, "terrain-S2-alternating.h5"), "block_file=" + blocks,
                "blocks=[rock-%s]" % name, "realizations=%d" % n, "outputs.hazard_cell_size=0"]
        tasks.append(lambda run=run, sets=sets: runner.dda_run(scene, sets, run))
        keys.append((name, run))
    log("lod: %d runs of %d realizations" % (len(tasks), n))
    cpus = runner.parallel(tasks)
    data = {name: (cpu, samples(read_run(run))) for (name, run), cpu in zip(keys, cpus)}
    ref = data["5120"][1]
    rows = []
    for name, _ in LOD:
        cpu, s = data[name]
        c = compare(ref, s)
        rows.append({"name": name, "ms_per_realization": 1e3 * cpu / n, "ks_max": c["ks_max"],
                     "toe_pp": c["toe_pp"], "vars": c["vars"], "failures": s["failures"]})
    return rows


def part_analytic(runner, n):
    ground = os.path.join(runner.inputs, "analytic-ground.yaml")
    with open(ground, "w") as f:
        f.write("materials:\n  - {name: ground, restitution_mean: 0.9, restitution_sd: 0, restitution_scale: 12,"
                " friction_angle_mean_deg: 0, friction_coefficient_sd: 0, lateral_tilt_sd_deg: 0}\n")
    plane = os.path.join(runner.inputs, "analytic-plane.h5")
    if not os.path.exists(plane):
        runner.tool("terrain-gen", "-c", ground, "--set", "name=analytic-plane", "--set", "synthetic.kind=plane",
                    "--set", "synthetic.cell_size=1", "--set", "synthetic.width=10", "--set", "synthetic.length=40",
                    "--set", "synthetic.slope_angle_deg=30", "-o", plane)
    cubes = os.path.join(runner.inputs, "cube.h5")
    if not os.path.exists(cubes):
        with open(os.path.join(runner.inputs, "cube.yaml"), "w") as f:
            f.write("blocks:\n  - {name: cube-1, solid: cube, volume: 1}\n")
        runner.tool("block-gen", "-c", os.path.join(runner.inputs, "cube.yaml"), "-o", cubes)
    scene = os.path.join(runner.inputs, "analytic-scene.yaml")
    with open(scene, "w") as f:
        f.write('schema_version: "1.0"\nterrain: none\nblock_file: none\nrealizations: 1\nseed: 1\n')
    theta = math.radians(30.0)
    common = ["terrain=" + plane, "block_file=" + cubes, "blocks=[cube-1]", "release.kind=line",
              "release.points=[[10.3,2.2],[11.7,7.9]]", "release.height_reference=lowest_point",
              "release.height=1e-6", "release.orientation=fixed", "release.orientation_deg=[0, 30, 0]",
              "stochastic.roughness=false", "stochastic.restitution=false", "stochastic.friction=false",
              "stochastic.lateral_tilt=false", "realizations=%d" % n, "outputs.hazard_cell_size=0"]
    tasks, keys = [], []
    for dof in ("rigid6", "full12"):
        for dt in ANALYTIC_DT:
            for omega in ANALYTIC_OMEGA:
                for kind, mu, seconds in (("slide", 0.2, 1.0), ("stick", 0.6, 10.0)):
                    run = os.path.join(runner.out, "analytic", "%s-%s-dt%g-omega%g.h5" % (kind, dof, dt, omega))
                    os.makedirs(os.path.dirname(run), exist_ok=True)
                    sets = common + ["materials=[{name: ground, friction_angle_mean_deg: %.17g}]" %
                                     math.degrees(math.atan(mu)), "engine.dof=" + dof, "engine.time_step=%g" % dt,
                                     "engine.penalty_omega=%g" % omega, "engine.max_time=%g" % seconds,
                                     "engine.rest_kinetic_energy=0"]
                    if kind == "stick":
                        sets.append("engine.trajectory_interval=0.01")
                    tasks.append(lambda run=run, sets=sets: runner.dda_run(scene, sets, run))
                    keys.append((kind, dof, dt, omega, mu, seconds, run))
                    if kind == "slide" and omega == ANALYTIC_OMEGA[0]:
                        # The same process for one step: its start-up cost, subtracted.
                        base = os.path.join(runner.out, "analytic", "startup-%s-dt%g.h5" % (dof, dt))
                        tasks.append(lambda run=base, sets=sets + ["engine.max_steps=1"]: runner.dda_run(scene, sets, run))
                        keys.append(("startup", dof, dt, omega, mu, 0.0, base))
    log("analytic: %d runs of %d realizations" % (len(tasks), n))
    cpus = runner.parallel(tasks)
    startup = {(k[1], k[2]): cpu for k, cpu in zip(keys, cpus) if k[0] == "startup"}
    rows = []
    for (kind, dof, dt, omega, mu, seconds, run), cpu in zip(keys, cpus):
        if kind == "startup":
            continue
        with h5py.File(run, "r") as f:
            r = f["records"]
            moved = np.linalg.norm(r["final_position"][:] - r["release_position"][:], axis=1)
            t = r["time"][:]
            ends = r["end_reason"][:]
            final = r["final_position"][:]
            traj = {k: f["trajectories"][k][:] for k in ("realization", "time", "position")} if kind == "stick" else None
        if kind == "slide":
            expected = 9.81 * (math.sin(theta) - mu * math.cos(theta)) * t ** 2 / 2
            error = float(np.max(np.abs(moved / expected - 1.0)))
        else:
            # Drift: the largest distance from the final centroid over the last 5 s (the
            # first seconds hold the springs' settling, about m g / k).
            error = 0.0
            for i in range(len(t)):
                sel = (traj["realization"] == i) & (traj["time"] >= t[i] - 5.0)
                error = max(error, float(np.max(np.linalg.norm(traj["position"][sel] - final[i], axis=1))))
        cost = max(cpu - startup[(dof, dt)], 0.0)
        rows.append({"kind": kind, "dof": dof, "dt": dt, "omega": omega, "error": error,
                     "ends": sorted(set(int(e) for e in ends)),
                     "ms_per_simulated_s": 1e3 * cost / (n * seconds)})
    return rows


# --- report ---------------------------------------------------------------------------


def front(points):
    """Indices of the non-dominated (cost, error) points, by increasing cost."""
    order = sorted(range(len(points)), key=lambda i: (points[i][0], points[i][1]))
    best, out = float("inf"), []
    for i in order:
        if points[i][1] < best:
            out.append(i)
            best = points[i][1]
    return out


def plot(results, out):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    if "study" in results:
        rows = [r for r in results["study"] if r["name"] != "reference"]
        floor = next((r["ks_max"] for r in rows if r["name"] == "floor"), None)
        rows = [r for r in rows if r["name"] != "floor"]
        fig, ax = plt.subplots(figsize=(8, 5.5))
        groups = sorted({r["group"] for r in rows})
        for g in groups:
            sel = [r for r in rows if r["group"] == g]
            ax.scatter([r["ms_per_realization"] for r in sel], [r["ks_max"] for r in sel], label=g, s=30)
            for r in sel:
                ax.annotate(r["name"], (r["ms_per_realization"], r["ks_max"]), fontsize=7,
                            xytext=(3, 3), textcoords="offset points")
        pts = [(r["ms_per_realization"], r["ks_max"]) for r in rows]
        f = front(pts)
        ax.plot([pts[i][0] for i in f], [pts[i][1] for i in f], "k--", lw=1, label="Pareto front")
        if floor is not None:
            ax.axhline(floor, color="grey", lw=1, ls=":", label="sampling floor (other seed)")
        ax.set_xscale("log")
        ax.set_xlabel("CPU time per realization (ms, one core)")
        ax.set_ylabel("largest KS distance to the reference (S1-S3, 5 outputs)")
        ax.set_title("Bench-slope study: error against cost per setting")
        ax.legend(fontsize=7)
        fig.tight_layout()
        for ext in ("png", "svg"):
            fig.savefig(os.path.join(out, "pareto-study." + ext), dpi=110)
        plt.close(fig)
    if "analytic" in results:
        fig, axes = plt.subplots(1, 2, figsize=(10, 4.2))
        for ax, kind, label in ((axes[0], "slide", "relative distance error after 1 s"),
                                (axes[1], "stick", "drift over the last 5 s of 10 s (m)")):
            for dof, marker in (("rigid6", "o"), ("full12", "s")):
                for omega in ANALYTIC_OMEGA:
                    sel = [r for r in results["analytic"] if r["kind"] == kind and r["dof"] == dof and r["omega"] == omega]
                    ax.plot([r["ms_per_simulated_s"] for r in sel], [max(r["error"], 1e-16) for r in sel],
                            marker=marker, label="%s, Omega %g" % (dof, omega), lw=1)
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlabel("CPU ms per simulated second")
            ax.set_ylabel(label)
            ax.set_title("%s (time step 0.2-4 ms along each line)" % kind)
        axes[0].legend(fontsize=7)
        fig.tight_layout()
        for ext in ("png", "svg"):
            fig.savefig(os.path.join(out, "pareto-analytic." + ext), dpi=110)
        plt.close(fig)


def tables(results):
    lines = []
    meta = results["meta"]
    lines.append("Measured %s on %s (%s, %d cores), commit %s; `bench/pareto/pareto.py %s`." % (
        meta["date"], meta["host"], meta["cpu"], meta["cores"], meta["commit"], meta["args"]))
    if "study" in results:
        rows = results["study"]
        pts = [(r["ms_per_realization"], r["ks_max"]) for r in rows if r["name"] not in ("reference", "floor")]
        names = [r["name"] for r in rows if r["name"] not in ("reference", "floor")]
        on_front = {names[i] for i in front(pts)}
        lines.append("")
        lines.append("| setting | group | ms / realization | KS max | runout KS | lateral KS | speed KS | jump KS | "
                     "toe energy KS | runout P95 shift | toe fraction S1/S2/S3 (Δ pp) | toe Δ to defaults (pp) | "
                     "failures | front |")
        lines.append("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|---|")
        for r in rows:
            worst = {v: max(r["levels"][lv]["vars"][v]["ks"] for lv, _ in LEVELS) for v in VARIABLES}
            p95 = max((r["levels"][lv]["vars"]["runout"]["p95"] for lv, _ in LEVELS), key=abs)
            toe = " / ".join("%.1f (%+.1f)" % (100 * r["levels"][lv]["toe"], r["levels"][lv]["toe_pp"])
                             for lv, _ in LEVELS)
            lines.append("| %s | %s | %.1f | %.3f | %.3f | %.3f | %.3f | %.3f | %.3f | %+.1f %% | %s | %.1f | %d | %s |" % (
                r["name"], r["group"], r["ms_per_realization"], r["ks_max"], worst["runout"], worst["lateral"],
                worst["max_speed"], worst["max_jump_height"], worst["toe_energy"], 100 * p95, toe,
                r.get("toe_pp_vs_default_max", float("nan")), r["failures"], "yes" if r["name"] in on_front else ""))
    if "lod" in results:
        lines.append("")
        lines.append("| rock triangles | ms / realization | KS max | runout KS | lateral KS | speed KS | jump KS | "
                     "toe fraction Δ (pp) | failures |")
        lines.append("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
        for r in results["lod"]:
            lines.append("| %s | %.1f | %.3f | %.3f | %.3f | %.3f | %.3f | %+.1f | %d |" % (
                r["name"], r["ms_per_realization"], r["ks_max"], r["vars"]["runout"]["ks"], r["vars"]["lateral"]["ks"],
                r["vars"]["max_speed"]["ks"], r["vars"]["max_jump_height"]["ks"], r["toe_pp"], r["failures"]))
    if "analytic" in results:
        lines.append("")
        lines.append("| case | DOF | time step (ms) | Omega | error | ms per simulated s | ends |")
        lines.append("|---|---|---:|---:|---:|---:|---|")
        for r in results["analytic"]:
            lines.append("| %s | %s | %g | %g | %.2e | %.1f | %s |" % (
                r["kind"], r["dof"], 1e3 * r["dt"], r["omega"], r["error"], r["ms_per_simulated_s"],
                ", ".join(str(e) for e in r["ends"])))
    return "\n".join(lines) + "\n"


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--bin", default=os.path.join(ROOT, "build", "bin"))
    p.add_argument("--out", default=os.path.join(ROOT, "out", "pareto"))
    p.add_argument("--realizations", type=int, default=1000, help="per level (study); lod and analytic scale from it")
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--part", default="study,lod,analytic")
    p.add_argument("--only", default="", help="study settings to run besides the reference (comma-separated names)")
    p.add_argument("--quick", action="store_true", help="250 realizations per level, a few settings")
    args = p.parse_args()
    if args.quick:
        args.realizations = min(args.realizations, 250)
    runner = Runner(args)
    parts = args.part.split(",")
    results = {"meta": {
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "host": platform.node(),
        "cpu": next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), "?"),
        "cores": os.cpu_count(),
        "commit": subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], capture_output=True,
                                 text=True).stdout.strip(),
        "args": " ".join(sys.argv[1:])}}
    n = args.realizations
    if "study" in parts:
        variants = STUDY
        if args.only:
            keep = set(args.only.split(",")) | {"reference", "floor"}
            variants = [v for v in STUDY if v[0] in keep]
        elif args.quick:
            variants = [v for v in STUDY if v[0] in ("reference", "floor", "default", "dt=2e-3", "omega=5", "oc=2")]
        results["study"] = part_study(runner, n, variants)
    if "lod" in parts:
        results["lod"] = part_lod(runner, max(50, n // 4))
    if "analytic" in parts:
        results["analytic"] = part_analytic(runner, 3)
    json.dump(results, open(os.path.join(runner.out, "results.json"), "w"), indent=1)
    text = tables(results)
    open(os.path.join(runner.out, "tables.md"), "w").write(text)
    plot(results, runner.out)
    print(text)


if __name__ == "__main__":
    main()
