#!/usr/bin/env python3
"""The quasi-static method against the paper's protocol, on ensembles of seeds.

Runs `gelsim compress` for each ensemble (bond preset x gel size x variant x seeds), then
compares the ensemble means of P_y(phi_k), contact number, ruptures by mode and the stored and
dissipated energy, with 95 % bootstrap confidence intervals over seeds, and writes
docs/quasistatic.md (with docs/quasistatic/results.json and plots).

    python3 tools/quasistatic_study.py                       # every ensemble below, 2 at a time
    python3 tools/quasistatic_study.py --only small-bond1    # one gel family
    python3 tools/quasistatic_study.py --variant quasistatic-walls4x --only small-bond1
    python3 tools/quasistatic_study.py --only paper4x-bond1 --variant quasistatic   # the 4x box: 65-80 min a run
    python3 tools/quasistatic_study.py --report-only         # tables from the cached runs

Runs are cached in --work (default ~/.cache/gel-studies/quasistatic): a finished run is never
run again, and an interrupted one resumes from its checkpoint, so the study can span sessions.
The finished runs' rows are also kept in docs/quasistatic/results.json, which is committed: a run
found there is not run again either, so the study goes on across machines whose cache is gone.
A run that is still missing is listed in the report as missing; nothing is extrapolated.

Only the Python standard library and gnuplot (Debian gnuplot-nox) are used.
"""
import argparse
import concurrent.futures
import json
import math
import os
import random
import shutil
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# Gel families. "small": about 1400 particles, 22 flocs of 64 in 150 x 250 (phi_0 = 0.118, the
# paper's aspect ratio 3:5); bond 2 uses the same box, so the same phi_0. "paper": the presets.
GELS = {
    "small-bond1": {"bond": {"preset": "bond1"},
                    "generator": {"lx": 150, "ly": 250, "n_floc": 64, "n_clusters": 22}},
    "small-bond2": {"bond": {"preset": "bond2"},
                    "generator": {"lx": 150, "ly": 250, "n_floc": 64, "n_clusters": 22}},
    "paper-bond1": {"preset": "paper-bond1"},
    "paper-bond2": {"preset": "paper-bond2"},
    # The 4x box (600 x 1000 a, 23 040 particles, the paper's phi_0 and floc size): does lambda_II
    # keep growing with the box (docs/exponents.md)? Seeds 1-3 took 3 900-4 700 s of CPU each,
    # 12-14x a paper-size run; only with --only.
    "paper4x-bond1": {"preset": "paper-bond1-4x"},
}
# Families run only when --only names them.
OPT_IN_GELS = ("paper4x-bond1",)
# Variants: the method under test, the reference ("paper", MODEL.md's protocol) and candidates
# for a faster method. wall_factor multiplies the bond set's reference wall speed (MODEL.md:
# 5e-4 v0 for bond 1, 1e-4 v0 for bond 2).
VARIANTS = {
    # The preset: walls at constant speed without the shortcut (the reference speed for bond 1,
    # 4x it for bond 2), walking at up to 4x dt while they carry less than 1e-2 F0/a^2 and at 2x
    # their speed once they carry 3e-2 F0/a^2, FIRE at each target. Every other "quasistatic-*"
    # variant pins the loaded walls it was measured with.
    "quasistatic": {"fidelity": "quasistatic"},
    "paper": {"fidelity": "paper"},
    # The other fidelity presets, measured against the same reference ensembles (docs/accuracy.md).
    # "default" is the preset as it was until 2026-12-04, spelled out: since then the preset of
    # that name is the quasi-static method, chosen by this comparison.
    "default": {"fidelity": "paper", "m_exam": 3000, "adaptive_wall_max_factor": 10, "adaptive_wall_drag_fraction": 0.5,
                "approach_shortcut": True},
    "fast": {"fidelity": "fast"},
    "quasistatic-walls4x": {"fidelity": "quasistatic", "loaded_wall_factor": 1, "wall_factor": 4},
    "quasistatic-walls2x": {"fidelity": "quasistatic", "loaded_wall_factor": 1, "wall_factor": 2},
    # The walls at the bond set's reference speed: the preset for bond 1, and the bond-2 preset
    # until 2026-12-03 (now 4x for bond 2, whose 8-seed ensemble at 4x agrees with "paper").
    "quasistatic-walls1x": {"fidelity": "quasistatic", "loaded_wall_factor": 1, "wall_factor": 1},
    # Slower than the paper's walls (the published-comparison issue: is the paper's speed the
    # slow-compression limit it claims?): half and a quarter of the bond set's reference speed.
    "quasistatic-walls0.5x": {"fidelity": "quasistatic", "loaded_wall_factor": 1, "wall_factor": 0.5},
    "quasistatic-walls0.25x": {"fidelity": "quasistatic", "loaded_wall_factor": 1, "wall_factor": 0.25},
    # Paper walls until a relaxed row spans, then affine strain steps each relaxed by FIRE.
    "quasistatic-walls-then-affine": {"fidelity": "quasistatic", "loaded_wall_factor": 1, "quasistatic_approach": "walls-then-affine"},
    # The preset as it was until 2026-12-03: walls as in "default" (adaptive up to x10, and the
    # top wall's group jumped from contact to contact until the network spans), FIRE cap 2e5.
    # Its ensembles came out 10-30 % below "paper" at phi >= 0.3.
    "quasistatic-jump-walls": {"fidelity": "quasistatic", "loaded_wall_factor": 1, "adaptive_wall_max_factor": 10, "adaptive_wall_drag_fraction": 0.5,
                               "approach_shortcut": True, "relax_max_iterations": 200000},
    # The jumps with constant walls: the same curve as with adaptive walls, so the jumps, not the
    # wall speed, made the difference.
    "quasistatic-constant-walls": {"fidelity": "quasistatic", "loaded_wall_factor": 1, "adaptive_wall_max_factor": 1, "approach_shortcut": True,
                                   "relax_max_iterations": 200000},
    # Twice the dynamics' time step (dt = 0.05 of the shortest period instead of 0.025) for the
    # wall walk, which is 84-88 % of a quasi-static run's steps; FIRE's largest step is kept where
    # it was (1.5 x gain x the doubled dt = 3 x gain x the old dt).
    "quasistatic-dt2": {"fidelity": "quasistatic", "loaded_wall_factor": 1, "dt_fraction": 0.05, "relax_dt_max_factor": 1.5},
    # Half the time step (0.0125 of the shortest period): is the preset's step converged? FIRE's
    # largest step is again kept where it was (6 x gain x the halved dt).
    "quasistatic-dt-half": {"fidelity": "quasistatic", "loaded_wall_factor": 1, "dt_fraction": 0.0125, "relax_dt_max_factor": 6},
    # The preset until 2026-12-07: every walk at the preset's dt. Since then the preset's walls
    # walk at up to 4x dt while they carry less than 1e-2 F0/a^2 (docs/quasistatic.md "Walk step").
    "quasistatic-walk-dt1": {"fidelity": "quasistatic", "loaded_wall_factor": 1, "walk_dt_factor": 1},
    # The next candidate measured (not the preset): a longer walk step (6x, within the cap) up to
    # a higher stress (3e-2 F0/a^2: bond 1 to phi ~ 0.42).
    "quasistatic-walkdt6-below3e-2": {"fidelity": "quasistatic", "loaded_wall_factor": 1, "walk_dt_factor": 6, "walk_dt_stress": 3e-2},
    # The loaded walk (from 1e-2 F0/a^2 on, at the scene's dt, about half of a paper-size bond-1
    # run) with walls at 2x the preset's speed: walls2x over the whole run moved P_y at phi <= 0.34
    # only, where this variant keeps the preset's walls.
    "quasistatic-loaded-walls2x": {"fidelity": "quasistatic", "loaded_wall_factor": 2, "loaded_wall_stress": 1e-2},
    # The same at 4x: faster walls over the whole run came within 6 % of the slow limit from
    # phi 0.37 on (docs/exponents.md).
    "quasistatic-loaded-walls4x": {"fidelity": "quasistatic", "loaded_wall_factor": 4, "loaded_wall_stress": 1e-2},
    # The preset until 2026-12-07 (evening): the walls at their speed all the way. Since then the
    # preset's walls move at 2x once they carry 3e-2 F0/a^2 (bond 1 from phi ~ 0.42, regime III):
    # from 1e-2 on, 2x lowered P_y by 5-16 % at phi 0.31-0.42 at the paper's size.
    "quasistatic-loaded-walls1x": {"fidelity": "quasistatic", "loaded_wall_factor": 1},
    # A candidate after the loaded walls: the walk step (4x dt, as the preset) up to 3e-2 F0/a^2,
    # where the loaded walls take over, instead of 1e-2: between the two (bond 1, paper size:
    # phi 0.33-0.42) a quarter of the preset's steps are walked at dt and 1x.
    "quasistatic-walkdt4-below3e-2": {"fidelity": "quasistatic", "walk_dt_stress": 3e-2},
}
# Variant keys copied as they are into the scene's compression message.
COMPRESSION_FIELDS = ("adaptive_wall_max_factor", "approach_shortcut", "adaptive_wall_drag_fraction", "m_exam",
                      "quasistatic_approach", "relax_max_iterations", "relax_dt_max_factor", "walk_dt_factor",
                      "walk_dt_stress", "loaded_wall_factor", "loaded_wall_stress")
REFERENCE = "paper"
DEFAULT_VARIANTS = ("quasistatic", "paper")
REFERENCE_WALL_SPEED = {"bond1": 5e-4, "bond2": 1e-4}
DEFAULT_SEEDS = {"small-bond1": 8, "small-bond2": 8, "paper-bond1": 4, "paper-bond2": 4, "paper4x-bond1": 4}

BOOTSTRAP_SAMPLES = 4000
# A percentile bootstrap over fewer seeds than this understates the interval badly (two seeds
# give at most three distinct means): no interval, and no verdict, is given below it.
MIN_SEEDS_FOR_INTERVAL = 4


def scene_for(gel, fidelity, seed):
    scene = json.loads(json.dumps(GELS[gel]))
    scene.setdefault("generator", {})["seed"] = seed
    variant = VARIANTS[fidelity]
    scene["compression"] = {"fidelity": variant["fidelity"]}
    for field in COMPRESSION_FIELDS:
        if field in variant:
            scene["compression"][field] = variant[field]
    if "dt_fraction" in variant:
        scene.setdefault("integration", {})["dt_fraction"] = variant["dt_fraction"]
    if "wall_factor" in variant:
        bond = "bond2" if gel.endswith("bond2") else "bond1"
        scene["compression"]["v_wall_v0"] = variant["wall_factor"] * REFERENCE_WALL_SPEED[bond]
    scene["name"] = f"quasistatic-study {gel} {fidelity}"
    return scene


def finished(curve):
    steps = curve.get("parameters", {}).get("compression", {}).get("steps", 0)
    return bool(curve.get("rows")) and curve["rows"][-1]["k"] == steps


def run_one(gelsim, work, gel, fidelity, seed, committed=None):
    if committed and (gel, fidelity, seed) in committed:
        return committed[(gel, fidelity, seed)]
    out_dir = os.path.join(work, gel, fidelity, f"seed_{seed}")
    curve_path = os.path.join(out_dir, "curve.json")
    scene = scene_for(gel, fidelity, seed)
    scene_path = os.path.join(out_dir, "scene.json")
    curve = cached(work, gel, fidelity, seed)
    if curve:
        return curve
    os.makedirs(out_dir, exist_ok=True)
    resume = os.path.exists(os.path.join(out_dir, "checkpoint.bin")) and os.path.exists(scene_path) \
        and json.load(open(scene_path)) == scene
    with open(scene_path, "w") as f:
        json.dump(scene, f, indent=1)
    command = [gelsim, "compress", "--no-snapshots"]
    # A fresh run replaces what an earlier one (another scene, an unreadable checkpoint) left;
    # gelsim keeps scene.json, gelsim.stderr and cpu_seconds.json, which it did not write.
    command += ["--resume", out_dir] if resume else ["--scene", scene_path, "--out", out_dir, "--overwrite"]
    # CPU seconds of this gelsim (its own rusage, not the pool's), summed over resumptions: on a
    # shared machine the wall time of a run says more about the neighbours than about the run.
    stderr_path = os.path.join(out_dir, "gelsim.stderr")
    with open(stderr_path, "w") as stderr:
        proc = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=stderr)
        _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    cpu_path = os.path.join(out_dir, "cpu_seconds.json")
    spent = json.load(open(cpu_path))["cpu_seconds"] if os.path.exists(cpu_path) else 0.0
    with open(cpu_path, "w") as f:
        json.dump({"cpu_seconds": spent + usage.ru_utime + usage.ru_stime}, f)
    if proc.returncode != 0:
        last = open(stderr_path).read().strip().splitlines()[-1:]
        if resume and proc.returncode == 2 and "does not read" in " ".join(last):
            # A checkpoint of an older format: the run is deterministic, so start it again.
            for name in ("checkpoint.bin", "checkpoint.prev.bin"):
                if os.path.exists(os.path.join(out_dir, name)):
                    os.remove(os.path.join(out_dir, name))
            print(f"{gel} {fidelity} seed {seed}: checkpoint of an older format, starting again", flush=True)
            return run_one(gelsim, work, gel, fidelity, seed, committed)
        raise RuntimeError(f"{gel} {fidelity} seed {seed}: gelsim exited {proc.returncode}: {last}")
    return cached(work, gel, fidelity, seed)


def cached(work, gel, fidelity, seed):
    path = os.path.join(work, gel, fidelity, f"seed_{seed}", "curve.json")
    if not os.path.exists(path):
        return None
    with open(path) as f:
        curve = json.load(f)
    cpu_path = os.path.join(work, gel, fidelity, f"seed_{seed}", "cpu_seconds.json")
    if os.path.exists(cpu_path):
        curve["cpu_seconds"] = json.load(open(cpu_path))["cpu_seconds"]
    return curve if finished(curve) else None


# --- Statistics -------------------------------------------------------------------------------

def mean(values):
    return sum(values) / len(values)


def bootstrap_mean(values, rng):
    """Mean and 95 % percentile interval of the mean over resampled seeds."""
    if len(values) < MIN_SEEDS_FOR_INTERVAL:
        return mean(values), float("nan"), float("nan")
    means = sorted(mean([rng.choice(values) for _ in values]) for _ in range(BOOTSTRAP_SAMPLES))
    return mean(values), means[int(0.025 * BOOTSTRAP_SAMPLES)], means[int(0.975 * BOOTSTRAP_SAMPLES) - 1]


def bootstrap_difference(a, b, rng):
    """95 % interval of mean(a) - mean(b), seeds resampled independently."""
    if len(a) < MIN_SEEDS_FOR_INTERVAL or len(b) < MIN_SEEDS_FOR_INTERVAL:
        return float("nan"), float("nan")
    diffs = sorted(mean([rng.choice(a) for _ in a]) - mean([rng.choice(b) for _ in b])
                   for _ in range(BOOTSTRAP_SAMPLES))
    return diffs[int(0.025 * BOOTSTRAP_SAMPLES)], diffs[int(0.975 * BOOTSTRAP_SAMPLES) - 1]


def row_summary(row):
    r = row["ruptures"]
    return {"k": row["k"], "phi": row["phi"], "P": row["P"], "P_top": row["P_top"], "P_bot": row["P_bot"],
            "z": row["contact_number"], "stored": row["stored_energy"],
            "dissipated": row["dissipated_energy"], "normal": r["normal"], "sliding": r["sliding"],
            "rolling": r["rolling"], "equilibrated": row["equilibrated"], "spans": row.get("spans", True),
            "residual_force": row.get("residual_force", 0.0), "mean_bond_force": row.get("mean_bond_force", 0.0),
            "relax_iterations": row.get("relax_iterations", 0), "steps": row["steps"], "wall_seconds": row["wall_seconds"]}


def row_from_summary(summary):
    """A curve row rebuilt from its summary in results.json (the fields the report reads)."""
    row = dict(summary)
    row["contact_number"] = row.pop("z")
    row["stored_energy"] = row.pop("stored")
    row["dissipated_energy"] = row.pop("dissipated")
    row["ruptures"] = {cause: row.pop(cause) for cause in ("normal", "sliding", "rolling")}
    row.setdefault("mean_bond_force", None)  # not kept before 2026-12-02: printed as "–"
    return row


def committed_runs():
    """Finished runs kept in docs/quasistatic/results.json, so that a study goes on from what an
    earlier machine measured when its cache is gone: {(gel, variant, seed): curve}."""
    path = os.path.join(ROOT, "docs", "quasistatic", "results.json")
    if not os.path.exists(path):
        return {}
    with open(path) as f:
        stored = json.load(f)
    return {(gel, variant, run["seed"]): {"seed": run["seed"], "particles": run["particles"],
                                          "rows": [row_from_summary(row) for row in run["rows"]],
                                          **({"cpu_seconds": run["cpu_seconds"]} if "cpu_seconds" in run else {})}
            for gel, variants in stored.items() for variant, runs in variants.items() for run in runs}


# --- Report -----------------------------------------------------------------------------------

def fmt(x, digits=3):
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "–"
    return f"{x:.{digits}g}"


def gnuplot(script, cwd):
    if shutil.which("gnuplot") is None:
        raise RuntimeError("gnuplot not found: install gnuplot-nox (scripts/setup.sh does)")
    subprocess.run(["gnuplot"], input=script, text=True, cwd=cwd, check=True)


def plot_curves(gel, ensembles, pictures, rng):
    """P_y(phi) of both fidelities, ensemble means with their bootstrap intervals."""
    lines = []
    for fidelity in VARIANTS:
        runs = ensembles.get(fidelity, [])
        if not runs:
            continue
        data = os.path.join(pictures, f"{gel}-{fidelity}.dat")
        with open(data, "w") as f:
            f.write("# phi_mean P_mean P_low P_high equilibrated_fraction\n")
            for k in range(1, min(len(r["rows"]) for r in runs)):
                ps = [r["rows"][k]["P"] for r in runs]
                m, low, high = bootstrap_mean(ps, rng)
                if m <= 0:
                    continue
                if math.isnan(low):
                    low = high = m
                low = max(low, 1e-5)  # an interval reaching P = 0 ends at the plot's floor
                phi = mean([r["rows"][k]["phi"] for r in runs])
                eq = mean([1.0 if r["rows"][k]["equilibrated"] else 0.0 for r in runs])
                f.write(f"{phi:.6g} {m:.6g} {low:.6g} {high:.6g} {eq:.3g}\n")
        lines.append(f"'{os.path.basename(data)}' using 1:2:3:4 with yerrorlines lw 2 pt 7 "
                     f"title '{fidelity} ({len(runs)} seeds)'")
    if not lines:
        return None
    name = f"{gel}-P_y.png"
    gnuplot("set terminal pngcairo size 720,520 font ',11'\n"
            f"set output '{name}'\nset logscale xy\nset xlabel 'φ'\nset ylabel 'P_y  [F_0/a^2]'\n"
            "set key top left\nset grid\nset format y '10^{%L}'\nset xrange [0.14:0.8]\n"
            "set xtics (0.15, 0.2, 0.3, 0.4, 0.5, 0.6, 0.74)\nset yrange [1e-5:1]\n"
            "plot " + ", ".join(lines) + "\n", pictures)
    return name


def write_report(args, results, rng):
    pictures = os.path.join(ROOT, "docs", "quasistatic")
    os.makedirs(pictures, exist_ok=True)
    out = []
    out.append("# Converged quasi-static compression\n")
    out.append(METHOD_TEXT)
    out.append("## Results\n")
    out.append(f"Generated by `python3 tools/quasistatic_study.py` on {time.strftime('%Y-%m-%d')} from the "
               "cached runs; every number below is an ensemble mean over the seeds named, with the 95 % "
               "bootstrap interval of the mean (seeds resampled, "
               f"{BOOTSTRAP_SAMPLES} samples) in brackets; with fewer than {MIN_SEEDS_FOR_INTERVAL} seeds "
               "no interval and no verdict is given. Raw per-run rows: "
               "[quasistatic/results.json](quasistatic/results.json).\n")
    for gel in GELS:
        ensembles = results.get(gel, {})
        if not any(ensembles.values()):
            out.append(f"### {gel}\n\nNo finished runs yet.\n")
            continue
        out.append(f"### {gel}\n")
        present = [v for v in VARIANTS if ensembles.get(v)]
        for fidelity in present:
            runs = ensembles.get(fidelity, [])
            if runs:
                times = [r["rows"][-1]["wall_seconds"] for r in runs]
                iters = [r["rows"][-1]["steps"] for r in runs]
                cpu = [r["cpu_seconds"] for r in runs if "cpu_seconds" in r]
                cpu_text = (f"CPU time per run {fmt(min(cpu))}–{fmt(max(cpu))} s ({len(cpu)} runs measured), "
                            if cpu else "")
                out.append(f"- `{fidelity}`: {len(runs)} seeds ({', '.join(str(r['seed']) for r in runs)}); "
                           f"wall time per run {fmt(min(times))}–{fmt(max(times))} s (mean {fmt(mean(times))} s), "
                           + cpu_text +
                           f"steps + FIRE iterations {fmt(mean(iters), 4)} per run; rows equilibrated "
                           f"{sum(1 for r in runs for row in r['rows'][1:] if row['equilibrated'])}/"
                           f"{sum(len(r['rows']) - 1 for r in runs)}.")
                if VARIANTS[fidelity]["fidelity"] == "quasistatic":
                    rows = [row for r in runs for row in r["rows"][1:]]
                    stuck = [f"seed {r['seed']} k {row['k']} (residual {fmt(row['residual_force'])} F0, "
                             f"mean bond force {fmt(row['mean_bond_force'])} F0)"
                             for r in runs for row in r["rows"][1:] if not row["equilibrated"]]
                    out.append(f"  FIRE iterations per target: median {fmt(sorted(row['relax_iterations'] for row in rows)[len(rows) // 2])}, "
                               f"max {fmt(max(row['relax_iterations'] for row in rows))}; rows not converged: "
                               + (", ".join(stuck) if stuck else "none") + ".")
            else:
                out.append(f"- `{fidelity}`: no finished run yet.")
        out.append("")
        candidates = [v for v in present if v != REFERENCE]
        ref_runs = ensembles.get(REFERENCE, [])
        header = "| k | φ_k | " + " | ".join(f"P_y {v} | eq." for v in present) + " | " + \
            " | ".join(f"{v} − {REFERENCE} (95 % CI) | agree" for v in candidates if ref_runs) + " |"
        header = header.replace("|  |", "|")
        out.append(header)
        out.append("|" + "---|" * (header.count("|") - 1))
        rows_count = max((len(r["rows"]) for v in present for r in ensembles[v]), default=0)
        for k in range(1, rows_count):
            cells = [str(k)]
            phis = [r["rows"][k]["phi"] for v in present for r in ensembles[v] if len(r["rows"]) > k]
            cells.append(fmt(mean(phis), 4) if phis else "–")
            values = {}
            for fidelity in present:
                runs = [r for r in ensembles[fidelity] if len(r["rows"]) > k]
                if not runs:
                    cells += ["–", "–"]
                    continue
                ps = [r["rows"][k]["P"] for r in runs]
                values[fidelity] = ps
                m, low, high = bootstrap_mean(ps, rng)
                cells.append(f"{fmt(m)} [{fmt(low)}, {fmt(high)}]")
                cells.append(f"{sum(1 for r in runs if r['rows'][k]['equilibrated'])}/{len(runs)}")
            for candidate in candidates if ref_runs else []:
                if candidate in values and REFERENCE in values:
                    low, high = bootstrap_difference(values[candidate], values[REFERENCE], rng)
                    cells.append(f"[{fmt(low)}, {fmt(high)}]")
                    cells.append("–" if math.isnan(low) else "yes" if low <= 0 <= high else "**no**")
                else:
                    cells += ["–", "–"]
            out.append("| " + " | ".join(cells) + " |")
        out.append("")
        out.append("At the last target (φ = 0.74), per particle:\n")
        header = "| observable | " + " | ".join(present) + " | " + \
            " | ".join(f"{v} − {REFERENCE} (95 % CI)" for v in candidates if ref_runs) + " |"
        header = header.replace("|  |", "|")
        out.append(header)
        out.append("|" + "---|" * (header.count("|") - 1))
        for key, label in (("z", "contact number z"), ("normal", "normal breaks / N"), ("sliding", "sliding resets / N"),
                           ("rolling", "rolling resets / N"), ("stored", "stored energy / N [F0 a]"),
                           ("dissipated", "dissipated energy / N [F0 a]")):
            cells = [label]
            values = {}
            for fidelity in present:
                runs = ensembles[fidelity]
                per = [row_summary(r["rows"][-1])[key] / (1 if key == "z" else r["particles"]) for r in runs]
                values[fidelity] = per
                m, low, high = bootstrap_mean(per, rng)
                cells.append(f"{fmt(m)} [{fmt(low)}, {fmt(high)}]")
            for candidate in candidates if ref_runs else []:
                low, high = bootstrap_difference(values[candidate], values[REFERENCE], rng)
                cells.append(f"[{fmt(low)}, {fmt(high)}]")
            out.append("| " + " | ".join(cells) + " |")
        out.append("")
        picture = plot_curves(gel, ensembles, pictures, rng)
        if picture:
            out.append(f"![P_y of {gel}](quasistatic/{picture})\n")
    with open(os.path.join(ROOT, "docs", "quasistatic.md"), "w") as f:
        f.write("\n".join(out) + "\n")
    compact = {gel: {fidelity: [{"seed": r["seed"], "particles": r["particles"],
                                 **({"cpu_seconds": r["cpu_seconds"]} if "cpu_seconds" in r else {}),
                                 "rows": [row_summary(row) for row in r["rows"]]}
                                for r in runs] for fidelity, runs in ensembles.items()}
               for gel, ensembles in results.items()}
    with open(os.path.join(pictures, "results.json"), "w") as f:
        json.dump(compact, f, indent=0)


METHOD_TEXT = open(os.path.join(ROOT, "docs", "quasistatic_method.md")).read() \
    if os.path.exists(os.path.join(ROOT, "docs", "quasistatic_method.md")) else ""


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--gelsim", default=os.path.join(ROOT, "build", "core", "gelsim"))
    parser.add_argument("--work", default=os.path.expanduser("~/.cache/gel-studies/quasistatic"))
    parser.add_argument("--only", action="append", choices=sorted(GELS), help="gel families to run (repeatable)")
    parser.add_argument("--variant", action="append", choices=sorted(VARIANTS),
                        help="variants to run (repeatable; default: quasistatic and paper)")
    parser.add_argument("--seeds", type=int, help="seeds 1..N per ensemble (default: 8 small, 4 paper size and 4x box)")
    parser.add_argument("--from-seed", type=int, default=1,
                        help="first seed to run (so that a second study process can take the later seeds)")
    parser.add_argument("--jobs", type=int, default=2, help="runs at a time")
    parser.add_argument("--report-only", action="store_true", help="no runs: tables from the cached runs")
    args = parser.parse_args()
    gels = args.only or [gel for gel in GELS if gel not in OPT_IN_GELS]
    fidelities = args.variant or list(DEFAULT_VARIANTS)

    if not args.report_only:
        # Seed-major, so that an interrupted study leaves comparable ensembles of both fidelities.
        committed = committed_runs()
        tasks = [(gel, fidelity, seed) for gel in gels
                 for seed in range(args.from_seed, (args.seeds or DEFAULT_SEEDS[gel]) + 1) for fidelity in fidelities]
        with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
            futures = {pool.submit(run_one, args.gelsim, args.work, *task, committed): task for task in tasks}
            for future in concurrent.futures.as_completed(futures):
                gel, fidelity, seed = futures[future]
                try:
                    curve = future.result()
                    print(f"{gel} {fidelity} seed {seed}: {curve['rows'][-1]['wall_seconds']:.0f} s", flush=True)
                except RuntimeError as error:
                    print(f"FAILED {error}", file=sys.stderr, flush=True)

    results = {}
    committed = committed_runs()
    for gel in GELS:
        for fidelity in VARIANTS:
            runs = []
            for seed in range(1, 65):
                curve = cached(args.work, gel, fidelity, seed) or committed.get((gel, fidelity, seed))
                if curve:
                    curve["seed"] = seed
                    runs.append(curve)
            results.setdefault(gel, {})[fidelity] = runs
    write_report(args, results, random.Random(20261202))


if __name__ == "__main__":
    main()
