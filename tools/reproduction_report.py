#!/usr/bin/env python3
"""A study analysis as a Markdown report with figures, in the terms of the paper it reproduces.

Reads the analysis of a study (JSON of format "gel.study-analysis.v1": `gelsim study --out DIR`
writes DIR/study_analysis.json, `gelctl study analysis ID --json` prints it) and writes a
Markdown report of what the model gives: one table of every observable of Seto, Botet,
Meireles, Auernhammer & Cabane, J. Rheol. 57 (2013), for each ensemble side by side with its
95 % interval and seeds; the rows and the rupture rates of each ensemble; the rows left out of
the fits and why; and the figures (PNG, gnuplot).

    /usr/bin/python3 tools/reproduction_report.py DIR/study_analysis.json --out docs/reproduction.md
    /usr/bin/python3 tools/reproduction_report.py DIR/study_analysis.json --out docs/reproduction.md \\
        --runs DIR --command "gelsim study --preset paper --out DIR" --cost "about 900 core-hours"

--runs DIR (the `gelsim study` directory: DIR/<ensemble>/seed_<seed>/curve.json) adds
snapshots of each ensemble's first seed at the initial row and at the first row of each regime,
drawn with `gelsim snapshot`; where DIR keeps no configurations (an archived study: curve.json and
structure.json only), pictures drawn earlier under the same names are kept and said to be.

The section "Against the paper" holds every published value of the paper beside the model's,
with its 95 % interval, seeds and a verdict (inside the published band, outside, or not
comparable and why); the same as a JSON list, written to --comparison (default
FIGURES/comparison.json: docs/reproduction/comparison.json for docs/reproduction.md). Besides
the study analysis's own numbers it computes, from the members' curve.json and structure.json
(--study DIR; default the folder of the analysis JSON when it holds them, else --runs): λ over
the paper's φ ranges, the onset of normal breaks per member, the gel-point form below φ = 0.2,
ξ^(0.5)'s exponent over several ranges, the span of P_y and the φ profile, each with a seeded
bootstrap over members (reproducible). It never changes the study analysis. Every number carries 3 significant digits and its interval as
"value [lo, hi]"; a missing number is "—", with the analysis's reason when it gives one.

Exit codes: 0 written; 2 the input is not a readable study analysis; 1 a figure could not be
drawn. Only the Python standard library and gnuplot (Debian gnuplot-nox) are used.
"""
import argparse
import json
import math
import os
import random
import re
import shutil
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FORMAT = "gel.study-analysis.v1"
REGIMES = (("elastic", "elastic"), ("single_mode_plastic", "single-mode plastic"),
           ("multi_mode_plastic", "multi-mode plastic"))
REGIME_NAMES = {"elastic": "elastic", "single-mode-plastic": "single-mode plastic",
                "multi-mode-plastic": "multi-mode plastic"}
MODES = (("gamma_normal", "Γ_N (normal breaks)", "#d62728"),
         ("gamma_sliding", "Γ_S (sliding resets)", "#1f77b4"),
         ("gamma_rolling", "Γ_R (rolling resets)", "#2ca02c"))
COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf")
FIT_DASH = {"elastic": 1, "single_mode_plastic": 2, "multi_mode_plastic": 4, "all": 3}
PHI_TARGETS = (0.3, 0.5, 0.7)
# A row stands for "P_y at phi = 0.5" only when it is within this factor of 0.5 (the targets of
# a compression are a geometric series with a ratio of about 1.1, so one row is always closer).
PHI_TOLERANCE = 1.1
DASH = "—"
# The study's bootstrap_samples: the resamples behind an Estimate that does not name them.
BOOTSTRAP = {"samples": None}


class InputError(Exception):
    """The input is not a study analysis this tool reads: exit code 2."""


# --- Numbers ----------------------------------------------------------------------------------

def finite(x):
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def num(x):
    """3 significant digits, exponents without padding (1.23e-5); "—" for nothing."""
    if not finite(x):
        return DASH
    if x == 0:
        return "0"
    text = f"{x:.3g}"
    if "e" in text:
        mantissa, exponent = text.split("e")
        text = f"{mantissa}e{int(exponent)}"
    return text


def value_of(estimate):
    """The value of an Estimate (or a bare number), None when there is none."""
    if isinstance(estimate, dict):
        estimate = estimate.get("value")
    return float(estimate) if finite(estimate) else None


def bounds_of(estimate):
    """(lo, hi) of an Estimate, each None when missing."""
    if not isinstance(estimate, dict):
        return None, None
    lo, hi = estimate.get("lo"), estimate.get("hi")
    return (float(lo) if finite(lo) else None), (float(hi) if finite(hi) else None)


def missing(reason=None):
    reason = " ".join(str(reason).split()) if reason else ""
    return f"{DASH} ({reason})" if reason else DASH


def est(estimate, short=False):
    """An Estimate as "value [lo, hi]"; without an interval, says why ("value [—]" when short);
    "—" when missing."""
    if isinstance(estimate, dict) and estimate.get("error") and value_of(estimate) is None:
        return missing(estimate["error"])
    value = value_of(estimate)
    if value is None:
        return missing(estimate.get("error") if isinstance(estimate, dict) else None)
    if not isinstance(estimate, dict):
        return num(value)
    lo, hi = bounds_of(estimate)
    if lo is not None and hi is not None:
        return f"{num(value)} [{num(lo)}, {num(hi)}]"
    if short:
        return f"{num(value)} [{DASH}]"
    n, resamples, with_value = estimate.get("n"), estimate.get("resamples", BOOTSTRAP["samples"]), \
        estimate.get("resamples_with_value")
    if finite(n) and n < 3:
        why = f"{int(n)} seed{'s' if n != 1 else ''}"
    elif finite(with_value) and finite(resamples) and resamples > 0:
        why = f"{int(with_value)} of {int(resamples)} resamples gave a value"
    elif finite(with_value):
        why = f"{int(with_value)} resamples gave a value"
    else:
        why = "none given"
    return f"{num(value)} (no interval: {why})"


def seeds_of(estimate):
    n = estimate.get("n") if isinstance(estimate, dict) else None
    return str(int(n)) if finite(n) else ""


def cell(text):
    """Text safe inside a Markdown table cell."""
    return " ".join(str(text).split()).replace("|", "\\|")


NO_INTERVAL = f"[{DASH}]: no interval (fewer than 3 seeds behind the value, or fewer than half of the " \
    "bootstrap resamples gave one)."


def table(header, rows):
    lines = ["| " + " | ".join(cell(h) for h in header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(cell(c) for c in row) + " |" for row in rows]
    text = "\n".join(lines) + "\n"
    return text + ("\n" + NO_INTERVAL + "\n" if f"[{DASH}]" in text else "")


def as_list(x):
    return x if isinstance(x, list) else []


def as_dict(x):
    return x if isinstance(x, dict) else {}


def phi_of(row):
    """phi of a row: an Estimate in rows, a bare number in excluded rows and xi rows."""
    return value_of(row.get("phi")) if isinstance(row, dict) else None


def seeds_text(seeds):
    seeds = [s for s in as_list(seeds) if finite(s)]
    if not seeds:
        return DASH
    seeds = [int(s) for s in seeds]
    if seeds == list(range(seeds[0], seeds[0] + len(seeds))) and len(seeds) > 2:
        return f"{seeds[0]}–{seeds[-1]}"
    return ", ".join(str(s) for s in seeds)


# --- Reading ----------------------------------------------------------------------------------

def load(path):
    try:
        with open(path) as f:
            analysis = json.load(f)
    except OSError as error:
        raise InputError(f"{path}: cannot read it: {error.strerror}")
    except json.JSONDecodeError as error:
        raise InputError(f"{path}: not JSON ({error}); expected a study analysis, format {FORMAT}")
    if not isinstance(analysis, dict):
        raise InputError(f"{path}: not a study analysis (a JSON object of format {FORMAT} was expected)")
    found = analysis.get("format")
    if found != FORMAT:
        raise InputError(f"{path}: format {json.dumps(found)} is not {FORMAT}; this tool reads the output of "
                         "`gelsim study` (study_analysis.json) or `gelctl study analysis ID --json`")
    ensembles = analysis.get("ensembles")
    if not isinstance(ensembles, list) or not ensembles or not all(isinstance(e, dict) for e in ensembles):
        raise InputError(f"{path}: \"ensembles\" must be a non-empty list of objects")
    for i, ensemble in enumerate(ensembles):
        if not isinstance(ensemble.get("name"), str) or not ensemble["name"]:
            raise InputError(f"{path}: ensembles[{i}].name is missing")
    return analysis


def rows_of(ensemble):
    return sorted((r for r in as_list(ensemble.get("rows")) if isinstance(r, dict) and finite(r.get("k"))),
                  key=lambda r: r["k"])


def intervals_of(ensemble):
    return sorted((i for i in as_list(ensemble.get("intervals")) if isinstance(i, dict) and finite(i.get("k"))),
                  key=lambda i: i["k"])


def fit_in(parent, key):
    """A fit under parent[key]: the fit object, {"error": why} when the analysis says why it failed
    (either inside the object or beside it as "<key>_error", the form gelsim writes), or None."""
    parent = as_dict(parent)
    fit = parent.get(key)
    if isinstance(fit, dict):
        return fit
    error = parent.get(key + "_error")
    return {"error": error} if isinstance(error, str) and error else None


def fit_of(ensemble, key):
    return fit_in(ensemble.get("power_law"), key)


def boundaries(ensemble):
    """[(label, Estimate)] of the regime boundaries that have a value."""
    regimes = as_dict(ensemble.get("regimes"))
    out = []
    for key, label in (("elastic_to_plastic_phi", "elastic → plastic"),
                       ("single_to_multi_mode_phi", "single → multi-mode")):
        if value_of(regimes.get(key)) is not None:
            out.append((label, regimes[key]))
    return out


def row_near(rows, target):
    """The row (k >= 1) whose phi is closest to target in ln phi, if one is within PHI_TOLERANCE."""
    best = None
    for row in rows:
        phi = phi_of(row)
        if row["k"] < 1 or phi is None or phi <= 0:
            continue
        distance = abs(math.log(phi / target))
        if best is None or distance < best[0]:
            best = (distance, row)
    if best is None or best[0] > math.log(PHI_TOLERANCE):
        return None
    return best[1]


def first_rows_of_regimes(ensemble):
    """{regime key: k} of the first row of each regime: from the rows' own "regime" when the
    analysis gives it, else from the first interval of the regime (its upper row), else from
    the boundaries and the trusted rows."""
    keys = {"elastic": "elastic", "single-mode-plastic": "single_mode_plastic",
            "multi-mode-plastic": "multi_mode_plastic"}
    first = {}
    for row in rows_of(ensemble):
        regime = keys.get(row.get("regime"))
        if regime and regime not in first:
            first[regime] = int(row["k"])
    if first:
        return first
    for interval in intervals_of(ensemble):
        regime = keys.get(interval.get("regime"))
        if regime and regime not in first:
            first[regime] = int(interval["k"])
    if first:
        return first
    regimes = as_dict(ensemble.get("regimes"))
    e2p = value_of(regimes.get("elastic_to_plastic_phi"))
    s2m = value_of(regimes.get("single_to_multi_mode_phi"))
    if e2p is None and s2m is None:
        return first
    for row in rows_of(ensemble):
        phi = phi_of(row)
        if not row.get("trusted") or phi is None:
            continue
        if e2p is not None and phi < e2p:
            regime = "elastic"
        elif s2m is not None and phi >= s2m:
            regime = "multi_mode_plastic"
        else:
            regime = "single_mode_plastic"
        first.setdefault(regime, int(row["k"]))
    return first


# --- Figures ----------------------------------------------------------------------------------

def gq(text):
    """A gnuplot single-quoted string."""
    return "'" + str(text).replace("'", "''") + "'"


def slug(name):
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("_") or "ensemble"


class Plotter:
    """Writes data files to a scratch folder and runs gnuplot there, one PNG per figure."""

    def __init__(self, figures, scratch):
        if shutil.which("gnuplot") is None:
            raise RuntimeError("gnuplot not found: install gnuplot-nox (scripts/setup.sh does)")
        self.figures, self.scratch, self.files = figures, scratch, 0
        listing = subprocess.run(["gnuplot", "-e", "set terminal"], capture_output=True, text=True)
        terminals = listing.stdout + listing.stderr
        self.cairo = re.search(r"^\s*pngcairo\b", terminals, re.M) is not None
        if not self.cairo and re.search(r"^\s*png\b", terminals, re.M) is None:
            raise RuntimeError("this gnuplot has neither the pngcairo nor the png terminal")

    def data(self, points):
        """A data file of rows of numbers; returns its name (relative to the scratch folder)."""
        self.files += 1
        name = f"d{self.files}.dat"
        with open(os.path.join(self.scratch, name), "w") as f:
            for point in points:
                f.write(" ".join(f"{x:.10g}" for x in point) + "\n")
        return name

    def draw(self, name, body, width=760, height=580):
        path = os.path.join(self.figures, name)
        if self.cairo:
            terminal = f"set terminal pngcairo enhanced size {width},{height} font ',11'"
        else:
            terminal = f"set terminal png enhanced size {width},{height}"
        script = f"{terminal}\nset encoding utf8\nset output {gq(os.path.abspath(path))}\n{body}\nunset output\n"
        proc = subprocess.run(["gnuplot"], input=script, text=True, cwd=self.scratch, capture_output=True)
        if proc.returncode != 0 or not os.path.exists(path):
            raise RuntimeError(f"gnuplot failed on {name}: {proc.stderr.strip()[-2000:]}")
        return path


def log_points(points):
    """(x, y, lo, hi, trusted) with y > 0, intervals clamped for a log axis."""
    kept = [p for p in points if p[1] is not None and p[1] > 0]
    if not kept:
        return [], None
    floor = min(min(p[1] for p in kept), min((p[2] for p in kept if p[2] is not None and p[2] > 0), default=math.inf))
    floor /= 2
    out = [(x, y, max(lo if lo is not None else y, floor), max(hi if hi is not None else y, y), trusted)
           for x, y, lo, hi, trusted in kept]
    return out, floor


def clause_pair(plot, points, colour, title, pt=7, dt=1, lines=True):
    """Plot clauses for trusted (filled, joined) and untrusted (open) points of one series."""
    clauses = []
    trusted = [(x, y, lo if lo is not None else y, hi if hi is not None else y) for x, y, lo, hi, t in points if t]
    others = [(x, y, lo if lo is not None else y, hi if hi is not None else y) for x, y, lo, hi, t in points if not t]
    style = "yerrorlines" if lines else "yerrorbars"
    if trusted:
        clauses.append(f"{gq(plot.data(trusted))} using 1:2:3:4 with {style} lw 2 dt {dt} pt {pt} ps 1 "
                       f"lc rgb {gq(colour)} title {gq(title)} noenhanced")
    if others:
        clauses.append(f"{gq(plot.data(others))} using 1:2:3:4 with yerrorbars lw 1 pt {pt - 1 if pt % 2 else pt} "
                       f"ps 1 lc rgb {gq(colour)} " + ("notitle" if trusted else f"title {gq(title)} noenhanced"))
    return clauses


def boundary_marks(ensemble, colour, cairo, label=True):
    """gnuplot commands: each regime boundary a vertical dashed line, its interval shaded."""
    out = []
    for text, estimate in boundaries(ensemble):
        x = value_of(estimate)
        lo, hi = bounds_of(estimate)
        if cairo and lo is not None and hi is not None and hi > lo > 0:
            out.append(f"set object rect from {lo:.10g}, graph 0 to {hi:.10g}, graph 1 behind "
                       f"fc rgb {gq(colour)} fs transparent solid 0.08 noborder")
        out.append(f"set arrow from {x:.10g}, graph 0 to {x:.10g}, graph 1 nohead dt 2 lw 1.5 lc rgb {gq(colour)}")
        if label:
            out.append(f"set label {gq(text)} at {x:.10g}, graph 0.98 rotate by 90 right offset -0.9,0 "
                       f"font ',9' textcolor rgb {gq(colour)} noenhanced")
    return out


def key_below(clauses):
    """The key in two columns under the plot, with a bottom margin that keeps it off the x label
    (gnuplot's automatic margin does not)."""
    entries = sum(1 for c in clauses if "notitle" not in c)
    return f"set key below width 1 font ',10' maxcols 2\nset bmargin {4 + math.ceil(entries / 2)}"


def x_range(xs, log):
    xs = [x for x in xs if x is not None and (x > 0 or not log)]
    if not xs:
        return ""
    lo, hi = min(xs), max(xs)
    if log:
        return f"set xrange [{lo / 1.06:.6g}:{hi * 1.06:.6g}]"
    pad = 0.04 * (hi - lo) if hi > lo else 0.02
    return f"set xrange [{lo - pad:.6g}:{hi + pad:.6g}]"


def phi_tics(lo, hi):
    tics = [t for t in (0.1, 0.12, 0.15, 0.2, 0.25, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9) if lo / 1.06 <= t <= hi * 1.06]
    return f"set xtics ({', '.join(f'{t:g}' for t in tics)})" if len(tics) >= 2 else ""


def figure_compression(plot, ensembles):
    clauses, setup, xs, floors = [], [], [], []
    for i, ensemble in enumerate(ensembles):
        colour = COLOURS[i % len(COLOURS)]
        points = []
        for row in rows_of(ensemble):
            if row["k"] < 1:
                continue
            lo, hi = bounds_of(row.get("P"))
            points.append((phi_of(row), value_of(row.get("P")), lo, hi, bool(row.get("trusted"))))
        points, floor = log_points([p for p in points if p[0] is not None and p[0] > 0])
        if not points:
            continue
        floors.append(floor)
        xs += [p[0] for p in points]
        clauses += clause_pair(plot, points, colour, ensemble["name"], lines=False)
        fits = [(key, label) for key, label in REGIMES if value_of(as_dict(fit_of(ensemble, key)).get("exponent")) is not None]
        if not fits and value_of(as_dict(fit_of(ensemble, "all")).get("exponent")) is not None:
            fits = [("all", "all trusted rows")]
        for key, label in fits:
            fit = fit_of(ensemble, key)
            exponent, prefactor = value_of(fit.get("exponent")), value_of(fit.get("prefactor"))
            a, b = fit.get("phi_min"), fit.get("phi_max")
            if prefactor is None or not finite(a) or not finite(b) or prefactor <= 0:
                continue
            clauses.append(f"(x >= {a:.10g} && x <= {b:.10g}) ? {prefactor:.10g} * x**({exponent:.10g}) : 1/0 "
                           f"with lines lw 2.5 dt {FIT_DASH[key]} lc rgb {gq(colour)} "
                           f"title {gq(ensemble['name'] + f' {label}: λ = {num(exponent)}')} noenhanced")
        setup += boundary_marks(ensemble, colour, plot.cairo)
    if not clauses:
        return None
    setup += ["set logscale xy", x_range(xs, True), phi_tics(min(xs), max(xs)),
              f"set yrange [{min(floors):.6g}:*]", "set format y '10^{%L}'", "set samples 2000",
              "set xlabel 'φ'", "set ylabel 'P_y  [F_0/a^2]'", key_below(clauses),
              "set grid", "set title 'Compression curves: ensemble means, 95 % intervals, power laws per regime'"]
    return plot.draw("compression.png", "\n".join(setup) + "\nplot " + ", \\\n  ".join(clauses), 820, 660)


def figure_ruptures(plot, ensembles):
    panels = []
    for i, ensemble in enumerate(ensembles):
        clauses, xs, floors = [], [], []
        for key, label, colour in MODES:
            points = []
            for interval in intervals_of(ensemble):
                lo, hi = bounds_of(interval.get(key))
                x = interval.get("phi_mid")
                if finite(x) and x > 0:
                    points.append((float(x), value_of(interval.get(key)), lo, hi, bool(interval.get("trusted"))))
            points, floor = log_points(points)
            if points:
                floors.append(floor)
                xs += [p[0] for p in points]
                clauses += clause_pair(plot, points, colour, label)
        if clauses:
            body = ["reset", "unset object", "unset arrow", "unset label"]
            body += boundary_marks(ensemble, "#555555", plot.cairo)
            body += ["set logscale xy", x_range(xs, True), phi_tics(min(xs), max(xs)),
                     f"set yrange [{min(floors):.6g}:*]", "set format y '10^{%L}'", "set grid",
                     "set xlabel 'φ (interval midpoint)'", "set ylabel 'Γ  [per particle per d ln φ]'",
                     key_below(clauses), f"set title {gq(ensemble['name'])} noenhanced",
                     "plot " + ", \\\n  ".join(clauses)]
            panels.append("\n".join(body))
    if not panels:
        return None
    columns = min(2, len(panels))
    rows = (len(panels) + columns - 1) // columns
    body = f"set multiplot layout {rows},{columns} title 'Rupture rates by mode (positive values)'\n" + \
        "\n".join(panels) + "\nunset multiplot"
    return plot.draw("rupture_rates.png", body, 600 * columns, 520 * rows + 40)


def figure_contacts(plot, ensembles):
    clauses, setup, xs = [], [], []
    for i, ensemble in enumerate(ensembles):
        colour = COLOURS[i % len(COLOURS)]
        points = []
        for row in rows_of(ensemble):
            z, phi = value_of(row.get("contact_number")), phi_of(row)
            if z is None or phi is None:
                continue
            lo, hi = bounds_of(row.get("contact_number"))
            points.append((phi, z, lo, hi, bool(row.get("trusted"))))
        if points:
            xs += [p[0] for p in points]
            clauses += clause_pair(plot, points, colour, ensemble["name"])
            setup += boundary_marks(ensemble, colour, plot.cairo)
    if not clauses:
        return None
    setup += [x_range(xs, False), "set grid", "set xlabel 'φ'", "set ylabel 'contact number z'",
              key_below(clauses), "set title 'Contact number: ensemble means, 95 % intervals'"]
    return plot.draw("contact_number.png", "\n".join(setup) + "\nplot " + ", \\\n  ".join(clauses))


def figure_energy(plot, ensembles):
    series, xs = [], []
    for i, ensemble in enumerate(ensembles):
        colour = COLOURS[i % len(COLOURS)]
        for key, label, pt, dt in (("stored_rate", "stored", 7, 1), ("dissipated_rate", "dissipated", 5, 2)):
            points = []
            for interval in intervals_of(ensemble):
                x, y = interval.get("phi_mid"), value_of(interval.get(key))
                if finite(x) and x > 0 and y is not None:
                    lo, hi = bounds_of(interval.get(key))
                    points.append((float(x), y, lo, hi, bool(interval.get("trusted"))))
            if points:
                xs += [p[0] for p in points]
                series.append((points, colour, f"{ensemble['name']} {label}", pt, dt))
    if not series:
        return None
    log_y = all(p[1] > 0 for s in series for p in s[0])
    clauses, floors = [], []
    for points, colour, title, pt, dt in series:
        if log_y:
            points, floor = log_points(points)
            floors.append(floor)
        clauses += clause_pair(plot, points, colour, title, pt=pt, dt=dt)
    setup = []
    for i, ensemble in enumerate(ensembles):
        if any(title.startswith(ensemble["name"] + " ") for _, _, title, _, _ in series):
            setup += boundary_marks(ensemble, COLOURS[i % len(COLOURS)], plot.cairo)
    setup += ["set logscale x", x_range(xs, True), phi_tics(min(xs), max(xs)), "set grid", "set xlabel 'φ (interval midpoint)'",
              "set ylabel 'dE / d ln φ  [F_0 a]'", key_below(clauses),
              "set title 'Energy increments: stored (solid) and dissipated (dashed) per d ln φ'"]
    if log_y:
        setup += ["set logscale y", f"set yrange [{min(floors):.6g}:*]", "set format y '10^{%L}'"]
    else:
        setup += ["set xzeroaxis lt -1"]
    return plot.draw("energy_increments.png", "\n".join(setup) + "\nplot " + ", \\\n  ".join(clauses))


def figure_xi(plot, ensembles):
    clauses, xs, floors = [], [], []
    for i, ensemble in enumerate(ensembles):
        colour = COLOURS[i % len(COLOURS)]
        points = []
        for row in as_list(ensemble.get("xi_05")):
            if not isinstance(row, dict):
                continue
            phi = phi_of(row)
            if phi is None or phi <= 0:
                continue
            lo, hi = bounds_of(row.get("xi"))
            points.append((phi, value_of(row.get("xi")), lo, hi, True))
        points, floor = log_points(points)
        if not points:
            continue
        floors.append(floor)
        xs += [p[0] for p in points]
        clauses += clause_pair(plot, points, colour, ensemble["name"], lines=False)
        fit = as_dict(fit_in(ensemble, "xi_power_law"))
        exponent, prefactor = value_of(fit.get("exponent")), value_of(fit.get("prefactor"))
        a, b = fit.get("phi_min"), fit.get("phi_max")
        if exponent is not None and prefactor is not None and prefactor > 0 and finite(a) and finite(b):
            clauses.append(f"(x >= {a:.10g} && x <= {b:.10g}) ? {prefactor:.10g} * x**({exponent:.10g}) : 1/0 "
                           f"with lines lw 2.5 lc rgb {gq(colour)} "
                           f"title {gq(ensemble['name'] + f' fit: exponent {num(exponent)}')} noenhanced")
    if not clauses:
        return None
    setup = ["set logscale xy", x_range(xs, True), phi_tics(min(xs), max(xs)), f"set yrange [{min(floors):.6g}:*]",
             "set samples 2000", "set grid", "set xlabel 'φ'", "set ylabel 'ξ^{(0.5)}  [a]'",
             key_below(clauses),
             "set title 'Length ξ^{(0.5)} against φ: ensemble means, 95 % intervals, power law'"]
    return plot.draw("xi_05.png", "\n".join(setup) + "\nplot " + ", \\\n  ".join(clauses))


def draw_snapshots(ensembles, runs, gelsim, figures):
    """{ensemble name: [(caption, png path)]} and notes on what could not be drawn."""
    drawn, notes = {}, []
    have_gelsim = os.path.isfile(gelsim) and os.access(gelsim, os.X_OK)
    no_gelsim, kept = [], {}
    labels = dict(REGIMES)
    for ensemble in ensembles:
        name = ensemble["name"]
        seeds = [s for s in as_list(ensemble.get("seeds")) if finite(s)]
        if not seeds:
            notes.append(f"`{name}`: no seeds listed, no snapshots.")
            continue
        seed = int(seeds[0])
        seed_dir = os.path.join(runs, name, f"seed_{seed}")
        try:
            with open(os.path.join(seed_dir, "curve.json")) as f:
                curve = json.load(f)
        except (OSError, ValueError) as error:
            why = error.strerror if isinstance(error, OSError) and error.strerror else str(error)
            notes.append(f"`{name}`: no snapshots, `{os.path.join(seed_dir, 'curve.json')}` could not be read ({why}).")
            continue
        curve_rows = {r.get("k"): r for r in as_list(as_dict(curve).get("rows")) if isinstance(r, dict)}
        wanted = [(0, "initial network")]
        for key, k in sorted(first_rows_of_regimes(ensemble).items(), key=lambda item: item[1]):
            if k == 0:
                continue
            if any(k == w[0] for w in wanted):
                wanted = [(w[0], w[1] + f", first {labels[key]} row" if w[0] == k else w[1]) for w in wanted]
            else:
                wanted.append((k, f"first {labels[key]} row"))
        for k, why in wanted:
            row = curve_rows.get(k)
            snapshot = row.get("snapshot") if row else None
            if not snapshot:
                notes.append(f"`{name}` seed {seed}, k = {k} ({why}): the curve has no snapshot for this row.")
                continue
            config = snapshot if os.path.isabs(snapshot) else os.path.join(seed_dir, snapshot)
            png = os.path.join(figures, f"snapshot_{slug(name)}_seed{seed}_k{k}.png")
            phi = row.get("phi")
            caption = f"k = {k}, φ = {num(phi)}: {why}" if finite(phi) else f"k = {k}: {why}"
            if not os.path.exists(config):
                if os.path.isfile(png) and os.path.getsize(png) > 0:
                    # A study directory that keeps only curve.json and structure.json (the archived
                    # paper study): the picture drawn earlier from the full directory is kept.
                    kept.setdefault((name, seed, seed_dir), []).append(k)
                    drawn.setdefault(name, []).append((caption, png))
                else:
                    notes.append(f"`{name}` seed {seed}, k = {k} ({why}): snapshot `{snapshot}` is missing.")
                continue
            if not have_gelsim:
                no_gelsim.append(f"{name} seed {seed} k = {k}")
                continue
            try:
                proc = subprocess.run([gelsim, "snapshot", config, "--out", png, "--size", "600"],
                                      capture_output=True, text=True, timeout=300)
                ok = proc.returncode == 0 and os.path.exists(png)
                error = (proc.stderr or proc.stdout).strip().splitlines()[-1:] if not ok else []
            except subprocess.TimeoutExpired:
                ok, error = False, ["timed out"]
            if not ok:
                notes.append(f"`{name}` seed {seed}, k = {k}: gelsim snapshot failed ({' '.join(error)}).")
                continue
            drawn.setdefault(name, []).append((caption, png))
    for (name, seed, seed_dir), ks in kept.items():
        notes.append(f"`{name}` seed {seed}, k = {', '.join(str(k) for k in ks)}: kept from an earlier report, not "
                     f"redrawn: `{seed_dir}` does not hold these rows' configurations (a study directory that keeps "
                     "only curve.json and structure.json per member).")
    if no_gelsim:
        notes.insert(0, f"Snapshots were not drawn: no gelsim program at `{gelsim}` (build it, or pass --gelsim); "
                        f"left out: {', '.join(no_gelsim)}.")
    return drawn, notes


# --- Against the paper ------------------------------------------------------------------------
# The published values of Seto et al. (2013), the analyses that can be held against them (from the
# members' curve.json and structure.json), and a verdict per observable. Nothing here feeds back
# into the model or the study analysis: the model's numbers are reported as they come.

VERDICTS = {"inside": "inside the published band", "outside": "outside", "not comparable": "not comparable"}
# The bootstrap of the analyses below: resample members with replacement, recompute, this many
# times, from random.Random seeded with this text, the ensemble's name and the quantity (so the
# report is the same on every run and no quantity's interval depends on another's).
PAPER_SAMPLES = 1000
PAPER_SEED = "reproduction_report.v1"
# Per bond of the paper (10 runs each), as stated in the paper's text.
PAPER_BONDS = {
    1: {"regime_II": (0.2, 0.31), "regime_III": 0.34, "normal_onset": (0.31, 0.34),
        "lambda_II": (5.8, 0.5), "lambda_III": (4.3, 0.2)},
    2: {"regime_II": (0.2, 0.42), "regime_III": 0.46, "normal_onset": (0.42, 0.46),
        "lambda_II": (5.8, 0.4), "lambda_III": (5.8, 0.4)},
}
PAPER_CONTEXT = (
    "From other studies in this repository (not recomputed by this report): the 1408-particle families "
    "(`small-bond1`, `small-bond2`) give λ_II ≈ 5.0–5.9, near the published 5.8, while the paper's box "
    "(5760 and 3840 particles) gives higher values (7.3–7.8 by earlier measures; this study's are in the table "
    "below): the single-mode plastic exponent differs between the two box sizes. The paper's own "
    "protocol never equilibrates the rows below φ ≈ 0.31, while every row of this study is at equilibrium, so "
    "the low-φ rows of the two are not the same measurement, and the low-φ numbers (λ_II, the gel point, the "
    "span of P_y, where dissipation overtakes storage) are the least comparable. The paper's own code, run on "
    "five of the same 1408-particle bond-1 gels (docs/reference_code.md, \"As ensembles\"), gives a λ_II inside "
    "the intervals of the product's `paper` and `quasistatic` runs of those gels, and all three intervals hold the "
    "published 5.8: on that box the codes agree, so the higher λ_II at the paper's size is not a difference between "
    "the product and the paper's code. Walls at half the paper's speed move λ_II by less than a unit, the box by "
    "2–3 units (docs/exponents.md).")


def bond_of(name):
    """The paper's bond (1 or 2) an ensemble stands for, from its name (bond1, paper-bond2, ...)."""
    match = re.search(r"bond[-_ ]?([12])(?!\d)", str(name))
    return int(match.group(1)) if match else None


def _float(x):
    return float(x) if finite(x) else None


def load_members(study, ensemble):
    """The members of an ensemble from STUDY/<name>/seed_<seed>/{curve,structure}.json:
    ([member], [note]); a member is {"seed", "particles", "rows": [row by k], "xi": {k: xi},
    "structure_options"}. Rows are cut to the shortest member, as the study analysis does."""
    members, notes = [], []
    for seed in as_list(ensemble.get("seeds")):
        if not finite(seed):
            continue
        seed_dir = os.path.join(study, ensemble["name"], f"seed_{int(seed)}")
        try:
            with open(os.path.join(seed_dir, "curve.json")) as f:
                curve = as_dict(json.load(f))
        except (OSError, ValueError):
            notes.append(f"seed {int(seed)}: no readable curve.json")
            continue
        rows = []
        for r in sorted((r for r in as_list(curve.get("rows")) if isinstance(r, dict) and finite(r.get("k"))),
                        key=lambda r: r["k"]):
            ruptures = as_dict(r.get("ruptures"))
            rows.append({"k": int(r["k"]), "phi": _float(r.get("phi")), "P": _float(r.get("P")),
                         "equilibrated": r.get("equilibrated") is True, "spans": r.get("spans") is True,
                         "normal": _float(ruptures.get("normal")), "sliding": _float(ruptures.get("sliding")),
                         "rolling": _float(ruptures.get("rolling")), "stored": _float(r.get("stored_energy")),
                         "dissipated": _float(r.get("dissipated_energy")),
                         "profile": [float(x) for x in as_list(r.get("phi_profile")) if finite(x)]})
        if not rows or [r["k"] for r in rows] != list(range(len(rows))) or any(r["phi"] is None for r in rows):
            notes.append(f"seed {int(seed)}: curve.json has no complete rows (k from 0, each with φ)")
            continue
        xi, options = {}, None
        try:
            with open(os.path.join(seed_dir, "structure.json")) as f:
                structure = as_dict(json.load(f))
            options = as_dict(structure.get("options"))
            for r in as_list(structure.get("rows")):
                if isinstance(r, dict) and finite(r.get("k")) and finite(r.get("xi_05")) and r["xi_05"] > 0:
                    xi[int(r["k"])] = float(r["xi_05"])
        except (OSError, ValueError):
            pass
        members.append({"seed": int(seed), "particles": _float(curve.get("particles")), "rows": rows, "xi": xi,
                        "structure_options": options})
    if members:
        shortest = min(len(m["rows"]) for m in members)
        for m in members:
            m["rows"] = m["rows"][:shortest]
    return members, notes


def percentile(values, q):
    """The q-th percentile (0-100), linear between order statistics."""
    values = sorted(values)
    pos = (len(values) - 1) * q / 100.0
    lo = int(math.floor(pos))
    hi = min(lo + 1, len(values) - 1)
    return values[lo] + (values[hi] - values[lo]) * (pos - lo)


def bootstrap(members, stat, key, discrete=False):
    """(lo, hi) of the 95 % percentile bootstrap of stat over members; (None, None) with fewer than 3
    members or when fewer than half of the resamples give a value. discrete: the order statistics
    themselves (no interpolation), for statistics that take a few values only."""
    if len(members) < 3:
        return None, None
    rng = random.Random(f"{PAPER_SEED}:{key}")
    values = []
    for _ in range(PAPER_SAMPLES):
        value = stat([members[rng.randrange(len(members))] for _ in members])
        if value is not None and math.isfinite(value):
            values.append(value)
    if len(values) < PAPER_SAMPLES / 2:
        return None, None
    if discrete:
        values.sort()
        return values[int(math.floor(0.025 * (len(values) - 1)))], values[int(math.ceil(0.975 * (len(values) - 1)))]
    return percentile(values, 2.5), percentile(values, 97.5)


def mean_of(members, k, key):
    values = [m["rows"][k][key] for m in members]
    return sum(values) / len(values) if values and all(v is not None for v in values) else None


def trusted_ks(members):
    """Rows k >= 1 where every member is equilibrated and spans (the study analysis's trusted rows)."""
    if not members:
        return []
    return [k for k in range(1, len(members[0]["rows"]))
            if all(m["rows"][k]["equilibrated"] and m["rows"][k]["spans"] for m in members)]


def loglog_slope(points):
    """Least-squares slope and intercept of ln y against ln x; None with fewer than 3 points."""
    points = [(math.log(x), math.log(y)) for x, y in points if x and y and x > 0 and y > 0]
    if len(points) < 3:
        return None
    mx = sum(p[0] for p in points) / len(points)
    my = sum(p[1] for p in points) / len(points)
    sxx = sum((p[0] - mx) ** 2 for p in points)
    if sxx <= 0:
        return None
    slope = sum((p[0] - mx) * (p[1] - my) for p in points) / sxx
    return slope, my - slope * mx


def ks_in(members, ks, lo=None, hi=None, lo_open=False, hi_open=False, digits=None):
    """The rows of ks whose mean φ (over all members), rounded to digits when given, lies in the range."""
    out = []
    for k in ks:
        phi = mean_of(members, k, "phi")
        if phi is None:
            continue
        if digits is not None:
            phi = round(phi, digits)
        if lo is not None and (phi < lo or (lo_open and phi == lo)):
            continue
        if hi is not None and (phi > hi or (hi_open and phi == hi)):
            continue
        out.append(k)
    return out


def rows_text(members, ks):
    if not ks:
        return "no rows"
    return f"k = {ks[0]}–{ks[-1]}, φ {num(mean_of(members, ks[0], 'phi'))}–{num(mean_of(members, ks[-1], 'phi'))}, " \
           f"{len(ks)} rows"


def entry(observable, name, published, band, model=None, interval=None, seeds=None, verdict=None, reason=None,
          phi_range=None, note=None, model_text=None, comparable=True):
    """One comparison: the verdict is computed from the model's value and the published band unless
    given; without a value or a band it is "not comparable", with the reason."""
    if verdict is None:
        if not comparable or model is None or band is None:
            verdict = "not comparable"
        else:
            verdict = "inside" if band[0] <= model <= band[1] else "outside"
    if verdict == "not comparable" and not reason:
        reason = "the model gives no value" if model is None else "the paper gives no band"
    notes = [note] if note else []
    if verdict == "outside" and interval and band and interval[0] is not None and interval[1] is not None \
            and interval[0] <= band[1] and interval[1] >= band[0]:
        notes.append("its 95 % interval reaches into the band")
    return {"observable": observable, "ensemble": name, "published": published,
            "published_band": list(band) if band else None, "model": model,
            "model_text": model_text if model_text is not None else
            (f"{num(model)} [{num(interval[0])}, {num(interval[1])}]" if model is not None and interval
             and interval[0] is not None and interval[1] is not None else (num(model) if model is not None else DASH)),
            "interval": list(interval) if interval and interval[0] is not None and interval[1] is not None else None,
            "seeds": seeds, "verdict": verdict, "reason": reason if verdict == "not comparable" else None,
            "phi_range": phi_range, "note": "; ".join(notes) or None}


def estimate_parts(estimate):
    """(value, interval, seeds) of an Estimate of the study analysis."""
    value = value_of(estimate)
    lo, hi = bounds_of(estimate)
    n = estimate.get("n") if isinstance(estimate, dict) else None
    return value, ((lo, hi) if lo is not None and hi is not None else None), (int(n) if finite(n) else None)


def compare_ensemble(ensemble, members, member_notes):
    """The comparison entries of one ensemble, and the extra analyses as text lines."""
    name, bond = ensemble["name"], bond_of(ensemble["name"])
    paper = PAPER_BONDS[bond]
    out = []
    n = len(members)
    rows = rows_of(ensemble)
    ks = trusted_ks(members)
    no_members = "no member curves (pass --study DIR, the `gelsim study` directory)" if not members else None
    boot = lambda stat, what, discrete=False: bootstrap(members, stat, f"{name}:{what}", discrete)  # noqa: E731

    # Initial networks: D_f.
    value, interval, seeds = estimate_parts(ensemble.get("fractal_dimension_initial"))
    options = next((m["structure_options"] for m in members if m.get("structure_options")), None) or {}
    rmin, rmax = options.get("fit_rmin"), options.get("fit_rmax")
    if finite(rmin) and finite(rmax):
        why = f"the model's C(r) is fitted over {rmin:g} < r/a < {rmax:g} (structure options), the paper's over " \
              "6 < r/a < 15; the archive keeps no configurations to refit over the paper's range"
    else:
        why = "the model's fit range of C(r) is not known here (no structure.json); the paper's is 6 < r/a < 15"
    inside = value is not None and 1.545 <= value <= 1.555
    out.append(entry("fractal dimension D_f of the initial networks", name,
                     "≈ 1.55 (C(r) a power law for 6 < r/a < 15)", (1.545, 1.555), value, interval, seeds,
                     comparable=False, reason=why,
                     note=None if value is None else f"read against the band alone it would be "
                     f"{'inside' if inside else 'outside'}"))

    # Contact number: from 2 to about 4.
    if rows:
        value, interval, seeds = estimate_parts(rows[0].get("contact_number"))
        out.append(entry("contact number, initial network", name, "2", (1.5, 2.5), value, interval, seeds,
                         phi_range=f"k = {int(rows[0]['k'])}, φ = {num(phi_of(rows[0]))}"))
        value, interval, seeds = estimate_parts(rows[-1].get("contact_number"))
        out.append(entry("contact number at the last row", name, "about 4 (at φ ≈ 0.74)", (3.5, 4.5), value,
                         interval, seeds, phi_range=f"k = {int(rows[-1]['k'])}, φ = {num(phi_of(rows[-1]))}"))

    # P_y spans about four decades from 0.16 to 0.74.
    if members:
        k16 = row_near([{"k": k, "phi": mean_of(members, k, "phi")} for k in range(len(members[0]["rows"]))], 0.16)
        k_last = len(members[0]["rows"]) - 1
    else:
        k16, k_last = None, None
    if k16 is not None and k16["k"] != k_last:
        k1 = k16["k"]

        def decades(draw):
            a, b = mean_of(draw, k1, "P"), mean_of(draw, k_last, "P")
            return math.log10(b / a) if a and b and a > 0 and b > 0 else None
        value = decades(members)
        spanning = [m for m in members if m["rows"][k1]["spans"]]
        span_value = decades(spanning) if spanning else None
        note = (f"mean P_y of all members at k = {k1} and k = {k_last}, as the study analysis's rows; "
                f"{len(spanning)} of {n} members span at k = {k1}")
        if span_value is not None and len(spanning) < n:
            note += f" (the spanning members alone: {num(span_value)} decades)"
        out.append(entry("decades of P_y from φ ≈ 0.16 to φ_max", name, "about 4 (φ ≈ 0.16 to 0.74)", (3.5, 4.5),
                         value, boot(decades, "decades"), n,
                         phi_range=f"φ {num(mean_of(members, k1, 'phi'))}–{num(mean_of(members, k_last, 'phi'))}",
                         note=note))
    else:
        out.append(entry("decades of P_y from φ ≈ 0.16 to φ_max", name, "about 4 (φ ≈ 0.16 to 0.74)", (3.5, 4.5),
                         reason=no_members or "no row near φ = 0.16"))

    # Dissipated exceeds stored from phi ~ 0.2.
    regimes = as_dict(ensemble.get("regimes"))
    value, interval, seeds = estimate_parts(regimes.get("elastic_to_plastic_phi"))
    upper = bool(regimes.get("elastic_to_plastic_at_first_trusted_row"))
    crossings = []
    for m in members:
        k = next((r["k"] for r in m["rows"][1:] if r["stored"] is not None and r["dissipated"] is not None
                  and r["dissipated"] >= r["stored"]), None)
        crossings.append((m["rows"][k - 1]["phi"], m["rows"][k]["phi"]) if k else None)
    band = (0.15, 0.25)
    reason, verdict, note = None, None, "the product's boundary (regime rule below), from the mean curve's trusted rows"
    if members and all(crossings):
        lo, hi = min(c[0] for c in crossings), max(c[1] for c in crossings)
        note += f"; per member the cumulative dissipated energy reaches the stored one between φ {num(lo)} and {num(hi)}"
        if band[0] <= lo and hi <= band[1]:
            verdict = "inside"
        elif hi < band[0] or lo > band[1]:
            verdict = "outside"
        else:
            verdict, reason = "not comparable", f"the rows do not resolve it: the crossing lies in ({num(lo)}, " \
                f"{num(hi)}], which straddles the band's edge; the rows the paper puts in its elastic regime " \
                f"(φ < 0.2) already dissipate more than they store in every member"
    elif upper and value is not None:
        if value < band[0]:
            verdict = "outside"
        else:
            verdict, reason = "not comparable", f"the model gives an upper bound only (≤ {num(value)}, the first " \
                "trusted row); pass --study for the members' rows below it"
    out.append(entry("elastic → plastic: dissipated energy exceeds stored from φ", name, "≈ 0.2", band, value,
                     interval, seeds, verdict=verdict, reason=reason, note=note,
                     model_text=("≤ " if upper else "") + est(regimes.get("elastic_to_plastic_phi"))))

    # At low phi only rolling ruptures.
    if members and all(r["sliding"] is not None and r["normal"] is not None for m in members for r in m["rows"]):
        def first_other(m):
            for k in range(1, len(m["rows"])):
                if m["rows"][k]["sliding"] + m["rows"][k]["normal"] > m["rows"][k - 1]["sliding"] + m["rows"][k - 1]["normal"]:
                    return k
            return len(m["rows"])

        def only_rolling_phi(draw):
            k = statistics.median_low([first_other(m) for m in draw])
            return mean_of(members, k - 1, "phi")
        firsts = [first_other(m) for m in members]
        rolling_first = all(m["rows"][1]["rolling"] and m["rows"][1]["rolling"] > 0 for m in members)
        holds = min(firsts) > 1 and rolling_first
        out.append(entry("only rolling ruptures at low φ: up to φ", name, "only rolling ruptures at low φ (no φ given)",
                         None, only_rolling_phi(members), boot(only_rolling_phi, "rolling", True), n,
                         verdict="inside" if holds else "outside",
                         note=f"qualitative statement, {'holds' if holds else 'does not hold'}: median over members "
                              f"of the last row before the first sliding reset or normal break (lowest member: "
                              f"φ = {num(mean_of(members, min(firsts) - 1, 'phi'))})"))
    else:
        out.append(entry("only rolling ruptures at low φ: up to φ", name, "only rolling ruptures at low φ (no φ given)",
                         None, reason=no_members or "the member curves have no rupture counts"))

    # Onset of normal breaks, per member.
    onset_band = paper["normal_onset"]
    published_onset = f"between {onset_band[0]:g} and {onset_band[1]:g}"
    if members and all(r["normal"] is not None for m in members for r in m["rows"]):
        K = len(members[0]["rows"])
        mids = {k: math.sqrt(mean_of(members, k - 1, "phi") * mean_of(members, k, "phi")) for k in range(1, K)}

        def onset(m, rule):
            breaks = [m["rows"][k]["normal"] - m["rows"][k - 1]["normal"] for k in range(1, K)]
            for k in range(1, K):
                if rule == "first" and breaks[k - 1] > 0:
                    return k
                if rule == "sustained" and all(b > 0 for b in breaks[k - 1:]):
                    return k
            return K  # never: after the last interval

        for rule, label in (("first", "first interval with a normal break"),
                            ("sustained", "first interval from which every later interval has a normal break")):
            def stat(draw, rule=rule):
                k = statistics.median_low([onset(m, rule) for m in draw])
                return mids.get(k)
            per = sorted(onset(m, rule) for m in members)
            counts = {}
            for k in per:
                counts[k] = counts.get(k, 0) + 1
            listing = ", ".join(f"({num(mean_of(members, k - 1, 'phi'))}, {num(mean_of(members, k, 'phi'))}] ×{c}"
                                if k < K else f"none ×{c}" for k, c in sorted(counts.items()))
            k_med = statistics.median_low(per)
            value = mids.get(k_med)
            out.append(entry(f"onset of normal breaks, per member ({rule})", name, published_onset, onset_band, value,
                             boot(stat, f"onset-{rule}", True), n,
                             phi_range=(f"interval ({num(mean_of(members, k_med - 1, 'phi'))}, "
                                        f"{num(mean_of(members, k_med, 'phi'))}]" if value is not None else None),
                             note=f"{label}; the value is that interval's φ_mid, the lower median over members "
                                  f"(interval: bootstrap of the median); by member: {listing}"))
            out[-1]["detail"] = rule == "sustained"
    else:
        for rule in ("first", "sustained"):
            out.append(entry(f"onset of normal breaks, per member ({rule})", name, published_onset, onset_band,
                             reason=no_members or "the member curves have no rupture counts"))

    # The product's pooled single -> multi-mode boundary.
    value, interval, seeds = estimate_parts(regimes.get("single_to_multi_mode_phi"))
    note = "the product's regime rule on the pooled (ensemble-mean) break rate"
    pooled = None
    if value is not None and members and all(r["normal"] is not None for m in members for r in m["rows"]):
        k0 = next((k for k in range(1, len(members[0]["rows"]))
                   if abs(mean_of(members, k - 1, "phi") - value) < 1e-9 * max(1.0, value)), None)
        if k0 is not None:
            breakers = [(m["seed"], m["rows"][k0]["normal"] - m["rows"][k0 - 1]["normal"]) for m in members
                        if m["rows"][k0]["normal"] > m["rows"][k0 - 1]["normal"]]
            total = sum(b for _, b in breakers)
            pooled = (f"pooled over members: its first interval has {int(total)} normal "
                      f"break{'s' if total != 1 else ''} in {len(breakers)} of {n} members; per member, breaks begin "
                      "later: see Against the paper")
            note += (f"; its first interval ({num(value)}, {num(mean_of(members, k0, 'phi'))}] has "
                     f"{int(total)} normal break{'s' if total != 1 else ''} in {len(breakers)} of {n} members "
                     f"(seed{'s' if len(breakers) != 1 else ''} {', '.join(str(s) for s, _ in breakers)}): "
                     "any break in any member makes the pooled rate positive")
    out.append(entry("single → multi-mode boundary φ (product's rule)", name,
                     f"regime II up to {paper['regime_II'][1]:g}, III from ≈ {paper['regime_III']:g}",
                     (paper["regime_II"][1], paper["regime_III"]), value, interval, seeds, note=note))
    if pooled:
        out[-1]["pooled"] = pooled

    # lambda over the paper's ranges, and the product's regime fits.
    # The paper's φ are its rows (the same series as the model's: 0.16, 0.176, 0.194, 0.214, ..., 0.313,
    # 0.344, ...) given to two digits, so its ranges are read on the rows' φ to two digits: regime II
    # "0.2 < φ < 0.31" holds the row at 0.313 (normal breaks start only after it, between 0.31 and
    # 0.34), regime III "above ≈ 0.46" starts at the row 0.459.
    for regime, key, (lo, hi, lo_open, hi_open), stated in (
            ("II", "single_mode_plastic", (paper["regime_II"][0], paper["regime_II"][1], True, False),
             f"{paper['regime_II'][0]:g} < φ < {paper['regime_II'][1]:g}"),
            ("III", "multi_mode_plastic", (paper["regime_III"], None, False, False), f"φ ≥ {paper['regime_III']:g}")):
        centre, sigma = paper[f"lambda_{regime}"]
        published = f"{centre:g} ± {sigma:g}"
        band = (centre - sigma, centre + sigma)
        fit_ks = ks_in(members, ks, lo, hi, lo_open, hi_open, digits=2)

        def lam(draw, fit_ks=fit_ks):
            fit = loglog_slope([(mean_of(draw, k, "phi"), mean_of(draw, k, "P")) for k in fit_ks])
            return fit[0] if fit else None
        value = lam(members) if members else None
        out.append(entry(f"λ_{regime}, P_y = C φ^λ over the paper's range", name, published, band, value,
                         boot(lam, f"lambda-{regime}") if value is not None else None, n or None,
                         phi_range=stated + " (the paper's rows, φ to two digits)",
                         reason=no_members or (f"fewer than 3 trusted rows in {stated}" if value is None else None),
                         note=f"mean curve of the members' equilibrated, spanning rows: {rows_text(members, fit_ks)}"
                         if members else None))
        fit = fit_of(ensemble, key)
        value, interval, seeds = estimate_parts(as_dict(fit).get("exponent"))
        label = dict(REGIMES)[key]
        out.append(entry(f"λ_{regime}: the product's {label} fit", name, published, band, value, interval, seeds,
                         phi_range=(f"φ {num(fit['phi_min'])}–{num(fit['phi_max'])}"
                                    if isinstance(fit, dict) and finite(fit.get("phi_min")) and finite(fit.get("phi_max"))
                                    else None),
                         reason=(as_dict(fit).get("error") if value is None else None),
                         note="over the product's regime rows (its own rule, not the paper's φ range)"))

    # The gel-point form over phi_g < phi < 0.2.
    if bond == 1:
        if members:
            below = [k for k in range(1, len(members[0]["rows"]))
                     if (mean_of(members, k, "phi") or 1) < 0.2 and (mean_of(members, k, "P") or 0) > 0]
            spanning = [k for k in below if all(m["rows"][k]["spans"] for m in members)]
            why = f"not determined ({len(below)} rows below φ = 0.2, {len(spanning)} of them with every member " \
                  f"spanning; 3 parameters)"
        else:
            why = no_members
        for label, published, band in (("gel point φ_g", "≈ 0.15", (0.145, 0.155)), ("λ′", "≈ 1.5", (1.45, 1.55))):
            out.append(entry(f"{label}, P_y = C′ (φ − φ_g)^λ′ over φ_g < φ < 0.2", name, published, band,
                             reason=why, phi_range="φ_g < φ < 0.2",
                             model_text="not determined" if members else DASH))
    gel = as_dict(ensemble.get("gel_point"))
    for label, key, published, band in (("gel point φ_g", "phi_g", "≈ 0.15", (0.145, 0.155)),
                                         ("λ′", "exponent", "≈ 1.5", (1.45, 1.55))):
        value, interval, seeds = estimate_parts(gel.get(key))
        wider = f"φ {num(gel.get('phi_min'))}–{num(gel.get('phi_max'))}" if finite(gel.get("phi_min")) else None
        out.append(entry(f"{label}: the product's gel-point fit", name,
                         published + (" (bond 1)" if bond == 1 else " (fitted to bond 1 only)"),
                         band if bond == 1 else None, value, interval, seeds, comparable=False, phi_range=wider,
                         reason=(f"the product fits over {wider}, not φ_g < φ < 0.2" if wider else
                                 (gel.get("error") or "no gel-point fit")) if bond == 1 else
                         "the paper fits the gel-point form to bond 1 only"))

    # xi^(0.5): the product's fit and its sensitivity to the range.
    value, interval, seeds = estimate_parts(as_dict(fit_in(ensemble, "xi_power_law")).get("exponent"))
    xi_fit = as_dict(fit_in(ensemble, "xi_power_law"))
    out.append(entry("exponent of ξ^(0.5) ∝ φ^x: the product's fit", name, "−1.96 ± 0.08", (-2.04, -1.88), value,
                     interval, seeds,
                     phi_range=f"φ {num(xi_fit.get('phi_min'))}–{num(xi_fit.get('phi_max'))}"
                     if finite(xi_fit.get("phi_min")) else None,
                     reason=xi_fit.get("error") if value is None else None,
                     note="the paper states one exponent (the fractal estimate −1/(d − D_f) ≈ −2.2); compared with "
                          "each bond"))
    xi_ks = [k for k in range(len(members[0]["rows"]))
             if all(k in m["xi"] for m in members)] if members else []
    for label, chosen in (("all rows with ξ", xi_ks), ("φ ≤ 0.5", ks_in(members, xi_ks, hi=0.5)),
                          ("k ≥ 1 (φ ≥ 0.16, the initial network left out)", [k for k in xi_ks if k >= 1]),
                          ("trusted rows only (every member spans)", [k for k in xi_ks if k in ks])):
        def slope(draw, chosen=chosen):
            fit = loglog_slope([(mean_of(draw, k, "phi"), sum(m["xi"][k] for m in draw) / len(draw)) for k in chosen])
            return fit[0] if fit else None
        value = slope(members) if members else None
        out.append(entry(f"exponent of ξ^(0.5) ∝ φ^x over {label}", name, "−1.96 ± 0.08", (-2.04, -1.88), value,
                         boot(slope, f"xi-{label}") if value is not None else None, n or None,
                         phi_range=rows_text(members, chosen) if members else None,
                         reason=no_members or ("fewer than 3 rows with ξ" if value is None else None),
                         note="members' structure.json ξ^(0.5), mean per row; the range of the paper's figure could "
                              "not be inferred from its text"))
        out[-1]["detail"] = True

    # phi profile: a drop in the middle at 0.16, uniform after.
    if members and all(len(r["profile"]) >= 5 for m in members for r in m["rows"]):
        def middle(m, k):
            p = m["rows"][k]["profile"]
            mean = sum(p) / len(p)
            mid = p[2 * len(p) // 5: 3 * len(p) // 5]
            return (sum(mid) / len(mid)) / mean if mean > 0 else None
        K = len(members[0]["rows"])
        k16 = row_near([{"k": k, "phi": mean_of(members, k, "phi")} for k in range(K)], 0.16)
        if k16 is not None:
            k1 = k16["k"]

            def ratio(draw, k=None):
                values = [middle(m, k1 if k is None else k) for m in draw]
                return sum(values) / len(values) if all(v is not None for v in values) else None
            uniform = next((k for k in range(k1 + 1, K) if all(abs(ratio(members, j) - 1) <= 0.05
                                                                for j in range(k, K))), None)
            value = ratio(members)
            interval = boot(ratio, "profile")
            holds = interval[1] is not None and interval[1] < 1 and uniform is not None
            out.append(entry("φ̄(y): middle fifth / mean at φ ≈ 0.16", name, "a drop in the middle at φ = 0.16, "
                             "uniform after", None, value, interval, n, verdict="inside" if holds else "outside",
                             phi_range=f"k = {k1}, φ = {num(mean_of(members, k1, 'phi'))}",
                             note=f"qualitative statement, {'holds' if holds else 'does not hold'}: ratio < 1 is a "
                                  "drop; uniform (the middle fifth within 5 % of the mean in every later row) from "
                                  + (f"φ = {num(mean_of(members, uniform, 'phi'))} on" if uniform is not None else
                                     "no row")))
    else:
        out.append(entry("φ̄(y): middle fifth / mean at φ ≈ 0.16", name, "a drop in the middle at φ = 0.16, uniform "
                         "after", None, reason=no_members or "the member curves have no φ profiles"))
    for e in out:
        if e["seeds"] is None and e["model"] is not None and members and e["verdict"] != "not comparable":
            e["seeds"] = n
    return out


def bending_entry():
    return entry("three-point bending threshold (validation)", "bond1", "0.22 F0 recovers, 0.23 F0 deforms plastically",
                 (0.22, 0.23), None, verdict="inside", model_text="between 0.22 and 0.23 F0",
                 note="reproduced by test ModelPins.BendingThresholdLiesBetween022And023 (a chain of 11 particles, "
                      "bond 1; not a study quantity)")


def comparison(analysis, study):
    """All comparison entries and notes on what could not be computed."""
    entries, notes = [], []
    for ensemble in analysis["ensembles"]:
        bond = bond_of(ensemble["name"])
        if bond is None:
            notes.append(f"`{ensemble['name']}` is not compared: its name names neither bond 1 nor bond 2.")
            continue
        members, member_notes = load_members(study, ensemble) if study else ([], [])
        if study and not members:
            notes.append(f"`{ensemble['name']}`: no member curves under `{study}` "
                         f"({'; '.join(member_notes) or 'none found'}); the analyses of the members are left out.")
        elif member_notes:
            notes.append(f"`{ensemble['name']}`: members left out: {'; '.join(member_notes)}.")
        entries += compare_ensemble(ensemble, members, member_notes)
    if any(bond_of(e["name"]) == 1 for e in analysis["ensembles"]):
        entries.append(bending_entry())
    return entries, notes


def short_model(e):
    """The model's value of an entry without its interval."""
    if e["verdict"] == "not comparable" and e["model"] is None:
        return e["model_text"] if e["model_text"] != DASH else "no value"
    return e["model_text"].split(" [")[0]


def verdict_text(e):
    text = VERDICTS[e["verdict"]]
    if e["verdict"] != "not comparable" and not e.get("published_band"):
        text += " (qualitative: the statement " + ("holds)" if e["verdict"] == "inside" else "does not hold)")
    return text + (f": {e['reason']}" if e.get("reason") else "")


def comparison_table(entries):
    header = ["observable", "bond", "published", "model [95 % interval]", "seeds", "φ range", "verdict", "note"]
    lines = [[e["observable"], e["ensemble"], e["published"], e["model_text"],
              str(e["seeds"]) if e["seeds"] is not None else DASH, e.get("phi_range") or DASH, verdict_text(e),
              e.get("note") or ""] for e in entries]
    return table(header, lines)


def find_study(args):
    """The study directory whose members the comparison reads: --study, else the folder of the
    analysis JSON when it holds members, else --runs; None when there is none."""
    if args.study:
        return args.study
    for candidate in (os.path.dirname(os.path.abspath(args.analysis)), args.runs):
        if candidate and os.path.isdir(candidate) and any(
                os.path.isdir(os.path.join(candidate, d)) and any(
                    os.path.isfile(os.path.join(candidate, d, s, "curve.json"))
                    for s in os.listdir(os.path.join(candidate, d)) if s.startswith("seed_"))
                for d in os.listdir(candidate)):
            return candidate
    return None


# --- Report -----------------------------------------------------------------------------------

def fit_details(fit, prefactor="C"):
    """Prefactor, phi range, points and residual of a fit; '' when it has none."""
    if not isinstance(fit, dict) or value_of(fit.get("exponent")) is None:
        return ""
    parts = []
    if fit.get("prefactor") is not None:
        parts.append(f"{prefactor} = {est(fit.get('prefactor'))}")
    if finite(fit.get("phi_min")) and finite(fit.get("phi_max")):
        parts.append(f"φ {num(fit['phi_min'])}–{num(fit['phi_max'])}")
    if finite(fit.get("points")):
        parts.append(f"{int(fit['points'])} rows")
    if finite(fit.get("rms_log_residual")):
        parts.append(f"rms ln residual {num(fit['rms_log_residual'])}")
    return "; ".join(parts)


def fit_exponent(fit, what="exponent"):
    if fit is None:
        return DASH, ""
    if not isinstance(fit, dict):
        return DASH, ""
    if value_of(fit.get(what)) is None:
        return missing(fit.get("error")), ""
    return est(fit.get(what)), seeds_of(fit.get(what))


def observables_table(ensembles, beside=None):
    """One table: every observable of every ensemble, value [95 % interval] and seeds. beside:
    {(ensemble name, boundary key): text} printed after a regime boundary."""
    beside = beside or {}
    header = ["observable", "unit"]
    for ensemble in ensembles:
        header += [ensemble["name"], "seeds"]
    lines = []

    def add(label, unit, cells):
        row = [label, unit]
        for value, seeds in cells:
            row += [value, seeds]
        lines.append(row)

    add("members (seeds)", "", [(f"{int(e['members'])}" if finite(e.get("members")) else DASH,
                                 seeds_text(e.get("seeds"))) for e in ensembles])
    add("particles N", "", [(str(int(e["particles"])) if finite(e.get("particles")) else DASH, "") for e in ensembles])
    add("trusted rows", "", [(f"{sum(1 for r in rows_of(e) if r.get('trusted'))} of {len(rows_of(e))}", "")
                             for e in ensembles])
    for key, label in (("elastic_to_plastic_phi", "elastic → plastic boundary φ"),
                       ("single_to_multi_mode_phi", "single → multi-mode boundary φ")):
        cells = []
        for e in ensembles:
            regimes = as_dict(e.get("regimes"))
            estimate = regimes.get(key)
            text = est(estimate)
            if key == "elastic_to_plastic_phi" and regimes.get("elastic_to_plastic_at_first_trusted_row"):
                # The first row that can be trusted already dissipated as much as it stores.
                text = "≤ " + text + " (the first trusted row: the elastic regime lies below the rows at equilibrium)"
            if beside.get((e["name"], key)):
                text += f" ({beside[(e['name'], key)]})"
            cells.append((text, seeds_of(estimate)))
        add(label, "", cells)
    for key, label in (("all", "all trusted rows"),) + REGIMES:
        add(f"λ, P_y = C φ^λ: {label}", "", [fit_exponent(fit_of(e, key)) for e in ensembles])
        add(f"  fit ({label})", "C in F0/a²", [(fit_details(fit_of(e, key)) or DASH, "") for e in ensembles])
    cells_phi, cells_exp, cells_fit = [], [], []
    for e in ensembles:
        gel = e.get("gel_point")
        if not isinstance(gel, dict):
            cells_phi.append((DASH, ""))
            cells_exp.append((DASH, ""))
            cells_fit.append((DASH, ""))
            continue
        if value_of(gel.get("phi_g")) is None and value_of(gel.get("exponent")) is None:
            cells_phi.append((missing(gel.get("error")), ""))
            cells_exp.append((missing(gel.get("error")), ""))
            cells_fit.append((DASH, ""))
            continue
        at_bound = " (at the bound φ_g = 0: not determined by the data)" if gel.get("at_bound") else ""
        if gel.get("converged") is False:
            at_bound += " (the fit on all seeds did not converge)"
        if finite(gel.get("resamples_at_bound")) and gel["resamples_at_bound"] > 0:
            total = f" of {int(samples)}" if finite(samples := BOOTSTRAP["samples"]) else ""
            at_bound += f"; at the bound in {int(gel['resamples_at_bound'])}{total} resamples"
        cells_phi.append((est(gel.get("phi_g")) + at_bound, seeds_of(gel.get("phi_g"))))
        cells_exp.append((est(gel.get("exponent")), seeds_of(gel.get("exponent"))))
        cells_fit.append((fit_details(gel, "C'") or DASH, ""))
    add("gel point φ_g, P_y = C' (φ − φ_g)^λ'", "", cells_phi)
    add("λ' (gel-point form)", "", cells_exp)
    add("  fit (gel-point form)", "C' in F0/a²", cells_fit)
    add("exponent of ξ^(0.5) = C φ^exponent", "", [fit_exponent(fit_in(e, "xi_power_law")) for e in ensembles])
    add("  fit (ξ^(0.5))", "C in a", [(fit_details(fit_in(e, "xi_power_law")) or DASH, "") for e in ensembles])
    add("fractal dimension D_f of the initial networks", "",
        [(est(e.get("fractal_dimension_initial")), seeds_of(e.get("fractal_dimension_initial"))) for e in ensembles])

    def at_row(e, row, quantity):
        if row is None:
            return DASH, ""
        if value_of(row.get(quantity)) is None:
            return est(row.get(quantity)), ""
        note = f" at φ = {num(phi_of(row))}, k = {int(row['k'])}" + ("" if row.get("trusted") else ", not trusted")
        return est(row.get(quantity)) + note, seeds_of(row.get(quantity))

    add("P_y at the last row", "F0/a²", [at_row(e, (rows_of(e) or [None])[-1], "P") for e in ensembles])
    add("contact number at the last row", "", [at_row(e, (rows_of(e) or [None])[-1], "contact_number")
                                               for e in ensembles])
    for target in PHI_TARGETS:
        cells = []
        for e in ensembles:
            row = row_near(rows_of(e), target)
            cells.append(at_row(e, row, "P") if row else (missing(f"no row near φ = {target:g}"), ""))
        add(f"P_y at φ ≈ {target:g}", "F0/a²", cells)
    return table(header, lines)


def rows_table(ensemble):
    rows = rows_of(ensemble)
    if not rows:
        return "No rows.\n"
    with_regime = any(r.get("regime") for r in rows)
    header = ["k", "φ", "P_y [F0/a²]", "contact number", "equilibrated / spanning members", "trusted"]
    if with_regime:
        header.insert(5, "regime")
    lines = []
    members = ensemble.get("members")
    for row in rows:
        def count(key):
            return str(int(row[key])) if finite(row.get(key)) else DASH
        out = [str(int(row["k"])), est(row.get("phi"), True), est(row.get("P"), True),
               est(row.get("contact_number"), True),
               f"{count('equilibrated_members')} / {count('spanning_members')}"
               + (f" of {int(members)}" if finite(members) else ""),
               "yes" if row.get("trusted") else "no"]
        if with_regime:
            out.insert(5, REGIME_NAMES.get(row.get("regime"), DASH))
        lines.append(out)
    return table(header, lines)


def intervals_table(ensemble):
    intervals = intervals_of(ensemble)
    if not intervals:
        return "No intervals.\n"
    header = ["k", "φ range", "φ_mid", "regime", "Γ_N", "Γ_S", "Γ_R", "stored dE/d ln φ [F0 a]",
              "dissipated dE/d ln φ [F0 a]", "trusted"]
    lines = []
    for interval in intervals:
        lines.append([str(int(interval["k"])), f"{num(interval.get('phi_lo'))}–{num(interval.get('phi_hi'))}",
                      num(interval.get("phi_mid")), REGIME_NAMES.get(interval.get("regime"), DASH),
                      est(interval.get("gamma_normal"), True), est(interval.get("gamma_sliding"), True),
                      est(interval.get("gamma_rolling"), True), est(interval.get("stored_rate"), True),
                      est(interval.get("dissipated_rate"), True), "yes" if interval.get("trusted") else "no"])
    return table(header, lines)


def against_paper(entries, notes, study, link, args):
    """The section "Against the paper": plain words, then the table of published values."""
    md = ["## Against the paper\n"]
    groups = {}
    for e in entries:
        groups.setdefault(e["verdict"], {}).setdefault(e["observable"], []).append(e["ensemble"])
    words = {"inside": "Inside the published band", "outside": "Outside the published band",
             "not comparable": "Not comparable"}
    if entries:
        md.append("In plain words, what the model reproduces of the published numbers (the table below gives the "
                  "numbers, bands and reasons):\n")
    for verdict in ("inside", "outside", "not comparable"):
        if verdict not in groups:
            continue
        items = []
        for obs in groups[verdict]:
            chosen = [e for e in entries if e["verdict"] == verdict and e["observable"] == obs and not e.get("detail")]
            if not chosen:
                continue
            if len({e["published"] for e in chosen}) == 1:
                values = ", ".join(f"{e['ensemble']} {short_model(e)}" for e in chosen)
                items.append(f"{obs}: {values} (published {chosen[0]['published']})")
            else:
                items.append(f"{obs}: " + ", ".join(f"{e['ensemble']} {short_model(e)} (published {e['published']})"
                                                   for e in chosen))
        if items:
            md.append(f"- **{words[verdict]}**: " + "; ".join(items) + ".")
    if any(e.get("detail") for e in entries):
        md.append("- The other rows of the table (ξ^(0.5) over other φ ranges, the onset of sustained normal "
                  "breaks) show how these numbers depend on the choices made.")
    md.append("")
    md.append(PAPER_CONTEXT + "\n")
    for e in entries:
        e.pop("detail", None)
    md.append("### Published values and the model\n")
    md.append("Published values: R. Seto et al., J. Rheol. 57, 1347 (2013), 10 runs per bond, P in F0/a². The "
              "published band is the stated range (\"between 0.31 and 0.34\"), value ± uncertainty where the "
              "paper gives one, and for a value given as \"≈ x\" or \"about x\" x ± half a unit of its last stated "
              "digit (≈ 0.2 → [0.15, 0.25], about 4 → [3.5, 4.5], ≈ 1.55 → 1.55 ± 0.005); a qualitative "
              "statement has no band and its verdict says whether the statement holds, by the criterion in the "
              "note. The verdict holds the model's value against the band; \"outside\" says when the model's "
              "95 % interval still reaches into it. Rows marked \"the product's\" repeat the study analysis "
              "above, unchanged; the others are computed by this report from the members' curve.json and "
              f"structure.json{f' in `{link(study)}`' if study else ''}, on the ensemble-mean curve, with a "
              f"95 % percentile bootstrap over members ({PAPER_SAMPLES} resamples with replacement, fixed seed "
              f"`{PAPER_SEED}`).\n")
    if entries:
        md.append(comparison_table(entries))
    else:
        md.append("No ensemble could be compared.\n")
    if not study:
        md.append("No study directory with member curves was found (the folder of the analysis JSON, --study or "
                  "--runs): the analyses of the members are left out.\n")
    for note in notes:
        md.append(f"- {note}")
    if notes:
        md.append("")
    return "\n".join(md)


def write_report(args, analysis, figures_dir):
    ensembles = analysis["ensembles"]
    BOOTSTRAP["samples"] = analysis.get("bootstrap_samples")
    out_dir = os.path.dirname(os.path.abspath(args.out))
    confidence = analysis.get("confidence") if finite(analysis.get("confidence")) else 0.95
    samples = analysis.get("bootstrap_samples")

    def link(path):
        return os.path.relpath(os.path.abspath(path), out_dir).replace(os.sep, "/")

    md = [f"# {args.title}\n"]
    inside = not os.path.relpath(out_dir, ROOT).startswith("..")
    model = f"[docs/model.md]({link(os.path.join(ROOT, 'docs', 'model.md'))})" if inside else "gelsim's docs/model.md"
    md.append(f"What the model of {model} gives for the observables of R. Seto, R. Botet, "
              "M. Meireles, G. K. Auernhammer and B. Cabane, *Compressive consolidation of strongly aggregated "
              "particle gels*, J. Rheol. 57, 1347 (2013). Generated by `tools/reproduction_report.py` from "
              f"`{os.path.basename(args.analysis)}` ({FORMAT}).\n")
    md.append("## What was run\n")
    for e in ensembles:
        rows = rows_of(e)
        members = int(e["members"]) if finite(e.get("members")) else len(as_list(e.get("seeds")))
        particles = f"N = {int(e['particles'])} particles" if finite(e.get("particles")) else "N not given"
        span = f"{len(rows)} rows (k = {int(rows[0]['k'])}–{int(rows[-1]['k'])}, φ = {num(phi_of(rows[0]))}–" \
               f"{num(phi_of(rows[-1]))})" if rows else "no rows"
        md.append(f"- `{e['name']}`: {members} seed{'s' if members != 1 else ''} ({seeds_text(e.get('seeds'))}), "
                  f"{particles}, {span}, {sum(1 for r in rows if r.get('trusted'))} trusted.")
    md.append("")
    if args.command:
        md.append("The study was made with:\n")
        md.append("    " + "\n    ".join(args.command.splitlines()) + "\n")
    if args.cost:
        md.append(f"Cost: {args.cost}\n")
    md.append("Units: φ is dimensionless, P_y in F0/a², energies in F0 a, rates per d ln φ (Γ: events per particle "
              "per d ln φ), ξ^(0.5) in a. Every number has 3 significant digits and its "
              f"{num(100 * confidence)} % interval as \"value [lo, hi]\"; {DASH} marks a value the analysis does "
              "not give, with its reason where it states one. \"seeds\" is the number of seeds behind each value.\n")

    study = find_study(args)
    entries, comparison_notes = comparison(analysis, study)
    beside = {(e["ensemble"], "single_to_multi_mode_phi"): e["pooled"] for e in entries if e.get("pooled")}
    for e in entries:
        e.pop("pooled", None)
    md.append("## Observables\n")
    md.append(observables_table(ensembles, beside))

    md.append(against_paper(entries, comparison_notes, study, link, args))

    for e in ensembles:
        md.append(f"## Ensemble `{e['name']}`\n")
        md.append("### Rows\n")
        md.append(rows_table(e))
        md.append("### Rupture rates and energy increments per interval\n")
        md.append("Interval k runs from row k − 1 to row k; φ_mid = √(φ_lo φ_hi). Γ_N, Γ_S, Γ_R: normal breaks, "
                  "sliding and rolling resets per particle per d ln φ.\n")
        md.append(intervals_table(e))

    md.append("## Rows left out of the fits\n")
    excluded = [(e["name"], r) for e in ensembles for r in as_list(e.get("excluded_rows")) if isinstance(r, dict)]
    if excluded:
        md.append(table(["ensemble", "k", "φ", "reason"],
                        [[name, str(int(r["k"])) if finite(r.get("k")) else DASH, num(phi_of(r)),
                          r.get("reason") or DASH] for name, r in excluded]))
    else:
        md.append("None.\n")

    md.append("## Figures\n")
    os.makedirs(figures_dir, exist_ok=True)
    open_note = "Filled symbols: trusted rows; open symbols: rows not trusted (left out of the fits; the initial " \
                "row k = 0 never is)."
    open_interval_note = "Filled symbols: trusted intervals (both rows trusted); open symbols: the others."
    captions = {
        "compression": "Figure 1. P_y(φ) of each ensemble on log-log axes, with the 95 % intervals as error bars; "
                       "lines: P_y = C φ^λ fitted in each regime, over its φ range (solid elastic, dashed "
                       "single-mode plastic, dash-dot multi-mode plastic; dotted: all trusted rows, drawn only "
                       "when no regime has a fit); vertical dashed lines: regime boundaries, shaded over their "
                       "intervals. " + open_note,
        "ruptures": "Figure 2. Rupture rates by mode against the interval midpoint φ_mid, one panel per ensemble; "
                    "only positive values appear on the log axis. Vertical dashed lines: regime boundaries. "
                    + open_interval_note,
        "contacts": "Figure 3. Contact number against φ, ensemble means with 95 % intervals. " + open_note,
        "energy": "Figure 4. Stored (solid) and dissipated (dashed) energy per d ln φ against φ_mid. "
                  + open_interval_note,
        "xi": "Figure 5. The length ξ^(0.5) against φ on log-log axes with its power-law fit over its φ range.",
    }
    drawers = (("compression", figure_compression), ("ruptures", figure_ruptures), ("contacts", figure_contacts),
               ("energy", figure_energy), ("xi", figure_xi))
    with tempfile.TemporaryDirectory(prefix="reproduction-report-") as scratch:
        plot = Plotter(figures_dir, scratch)
        for key, draw in drawers:
            path = draw(plot, ensembles)
            if path:
                md.append(f"![{captions[key].split('.')[0]}]({link(path)})\n")
                md.append(f"*{captions[key]}*\n")
            elif key == "xi":
                md.append("Figure 5 (ξ^(0.5) against φ) is not drawn: the analysis has no positive ξ^(0.5) "
                          "values (a study run with its structure analyses gives them).\n")
            else:
                md.append(f"{captions[key].split('.')[0]} is not drawn: the analysis has no values to plot.\n")

    md.append("### Snapshots\n")
    if args.runs:
        drawn, notes = draw_snapshots(ensembles, args.runs, args.gelsim, figures_dir)
        for e in ensembles:
            pictures = drawn.get(e["name"])
            if not pictures:
                continue
            md.append(f"`{e['name']}`, seed {int(as_list(e.get('seeds'))[0])} (`gelsim snapshot`):\n")
            md.append("| " + " | ".join(cell(c) for c, _ in pictures) + " |")
            md.append("|" + "---|" * len(pictures))
            md.append("| " + " | ".join(f"![{cell(c)}]({link(p)})" for c, p in pictures) + " |\n")
        for note in notes:
            md.append(f"- {note}")
        if notes:
            md.append("")
    else:
        md.append("Not drawn: the report was made without --runs (the study directory that holds the "
                  "configurations).\n")

    md.append("## Notes\n")
    method = (f"Every value is computed on the mean curve of all seeds of an ensemble, and its interval is the "
              f"{num(100 * confidence)} % percentile bootstrap over seeds"
              + (f" ({int(samples)} resamples, each" if finite(samples) else " (each resample")
              + " repeating the whole analysis, regime boundaries included). "
              "Fits and regime boundaries use the trusted rows only (rows whose members are equilibrated and "
              "span the walls); the initial row k = 0 never enters a fit.")
    md.append(method + "\n")
    rules = sorted({as_dict(e.get("regimes")).get("rule") for e in ensembles
                    if isinstance(as_dict(e.get("regimes")).get("rule"), str)})
    for rule in rules:
        md.append(f"Regime rule (from the analysis): {' '.join(rule.split())}\n")
    seconds = [e.get("structure_seconds") for e in ensembles if finite(e.get("structure_seconds"))]
    if seconds and sum(seconds) > 0:
        md.append(f"The structure analyses (ξ^(0.5), D_f) took {num(sum(seconds))} s over all members.\n")

    comparison_path = args.comparison or os.path.join(figures_dir, "comparison.json")
    os.makedirs(os.path.dirname(os.path.abspath(comparison_path)), exist_ok=True)
    with open(comparison_path, "w") as f:
        json.dump(entries, f, indent=1, ensure_ascii=False)
        f.write("\n")
    with open(args.out, "w") as f:
        f.write("\n".join(md).rstrip("\n") + "\n")
    return comparison_path


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("analysis", help=f"study analysis JSON ({FORMAT})")
    parser.add_argument("--out", required=True, help="Markdown report to write (e.g. docs/reproduction.md)")
    parser.add_argument("--figures", help="folder of the PNG figures (default: OUT without .md)")
    parser.add_argument("--runs", help="the `gelsim study` directory, for snapshots of the configurations")
    parser.add_argument("--gelsim", default=os.path.join(ROOT, "build", "core", "gelsim"),
                        help="gelsim program that draws the snapshots (default: build/core/gelsim)")
    parser.add_argument("--title", default="Compressive consolidation of strongly aggregated particle gels: "
                                           "what the model gives")
    parser.add_argument("--study", help="the `gelsim study` directory whose members (<ensemble>/seed_<seed>/"
                                        "curve.json, structure.json) the comparison with the paper reads "
                                        "(default: the folder of ANALYSIS when it holds them, else --runs)")
    parser.add_argument("--comparison", help="the comparison with the published values as JSON "
                                             "(default: FIGURES/comparison.json)")
    parser.add_argument("--command", help="the command that made the study (printed in the report)")
    parser.add_argument("--cost", help="text on the cost of the study, e.g. core-hours (printed in the report)")
    args = parser.parse_args()
    try:
        analysis = load(args.analysis)
    except InputError as error:
        print(f"reproduction_report: {error}", file=sys.stderr)
        return 2
    for option, path in (("--runs", args.runs), ("--study", args.study)):
        if path and not os.path.isdir(path):
            print(f"reproduction_report: {option} {path}: not a directory", file=sys.stderr)
            return 2
    figures = args.figures or (args.out[:-3] if args.out.endswith(".md") else args.out + "_figures")
    out_dir = os.path.dirname(os.path.abspath(args.out))
    os.makedirs(out_dir, exist_ok=True)
    try:
        comparison_path = write_report(args, analysis, figures)
    except (RuntimeError, OSError) as error:
        print(f"reproduction_report: {error}", file=sys.stderr)
        return 1
    print(f"written {args.out} (figures in {figures}, comparison with the paper in {comparison_path})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
