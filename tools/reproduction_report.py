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
drawn with `gelsim snapshot`. Every number carries 3 significant digits and its interval as
"value [lo, hi]"; a missing number is "—", with the analysis's reason when it gives one.

Exit codes: 0 written; 2 the input is not a readable study analysis; 1 a figure could not be
drawn. Only the Python standard library and gnuplot (Debian gnuplot-nox) are used.
"""
import argparse
import json
import math
import os
import re
import shutil
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
    if not (os.path.isfile(gelsim) and os.access(gelsim, os.X_OK)):
        notes.append(f"Snapshots were not drawn: no gelsim program at `{gelsim}` (build it, or pass --gelsim).")
        return drawn, notes
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
            if not os.path.exists(config):
                notes.append(f"`{name}` seed {seed}, k = {k} ({why}): snapshot `{snapshot}` is missing.")
                continue
            png = os.path.join(figures, f"snapshot_{slug(name)}_seed{seed}_k{k}.png")
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
            phi = row.get("phi")
            caption = f"k = {k}, φ = {num(phi)}: {why}" if finite(phi) else f"k = {k}: {why}"
            drawn.setdefault(name, []).append((caption, png))
    return drawn, notes


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


def observables_table(ensembles):
    """One table: every observable of every ensemble, value [95 % interval] and seeds."""
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

    md.append("## Observables\n")
    md.append(observables_table(ensembles))

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

    with open(args.out, "w") as f:
        f.write("\n".join(md).rstrip("\n") + "\n")


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
    parser.add_argument("--command", help="the command that made the study (printed in the report)")
    parser.add_argument("--cost", help="text on the cost of the study, e.g. core-hours (printed in the report)")
    args = parser.parse_args()
    try:
        analysis = load(args.analysis)
    except InputError as error:
        print(f"reproduction_report: {error}", file=sys.stderr)
        return 2
    if args.runs and not os.path.isdir(args.runs):
        print(f"reproduction_report: --runs {args.runs}: not a directory", file=sys.stderr)
        return 2
    figures = args.figures or (args.out[:-3] if args.out.endswith(".md") else args.out + "_figures")
    out_dir = os.path.dirname(os.path.abspath(args.out))
    os.makedirs(out_dir, exist_ok=True)
    try:
        write_report(args, analysis, figures)
    except (RuntimeError, OSError) as error:
        print(f"reproduction_report: {error}", file=sys.stderr)
        return 1
    print(f"written {args.out} (figures in {figures})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
