"""The report's figures (PNG, drawn by gnuplot) and the snapshots of configurations (drawn by
`gelsim snapshot`)."""
import json
import math
import os
import re
import shutil
import subprocess

from .analysis import (REGIMES, as_dict, as_list, bounds_of, boundaries, finite, first_rows_of_regimes, fit_in,
                       fit_of, intervals_of, phi_of, rows_of, value_of)
from .text import num

MODES = (("gamma_normal", "Γ_N (normal breaks)", "#d62728"),
         ("gamma_sliding", "Γ_S (sliding resets)", "#1f77b4"),
         ("gamma_rolling", "Γ_R (rolling resets)", "#2ca02c"))
COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf")
FIT_DASH = {"elastic": 1, "single_mode_plastic": 2, "multi_mode_plastic": 4, "all": 3}


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


def boundary_marks(ensemble, colour, cairo, labels=None):
    """gnuplot commands: each regime boundary a vertical dashed line, its interval shaded. Its label
    (text, x, colour) goes to `labels`, for boundary_labels to set above the frame."""
    out = []
    for text, estimate in boundaries(ensemble):
        x = value_of(estimate)
        lo, hi = bounds_of(estimate)
        if cairo and lo is not None and hi is not None and hi > lo > 0:
            out.append(f"set object rect from {lo:.10g}, graph 0 to {hi:.10g}, graph 1 behind "
                       f"fc rgb {gq(colour)} fs transparent solid 0.08 noborder")
        out.append(f"set arrow from {x:.10g}, graph 0 to {x:.10g}, graph 1 nohead dt 2 lw 1.5 lc rgb {gq(colour)}")
        if labels is not None:
            labels.append((text, x, colour))
    return out


def boundary_labels(labels, xs, log, width, above=2.2):
    """gnuplot commands: the boundaries' labels above the frame, where no data point is, each
    beside its line (to the right, or to the left where the text would run past the frame), a
    label that would overlap another a row higher; the title goes above the rows. `width` is the
    figure's (or panel's) width in pixels, for an estimate of the labels' lengths; `above` the
    character heights kept above the rows (the title's, and a multiplot's own title's)."""
    xs = [x for x in xs if x is not None and (x > 0 or not log)]
    if not labels or not xs:
        return []
    lo, hi = min(xs), max(xs)
    if log:
        lo, hi = math.log(lo / 1.06), math.log(hi * 1.06)
    else:
        pad = 0.04 * (hi - lo) if hi > lo else 0.02
        lo, hi = lo - pad, hi + pad
    char = 6.5 / max(100, width - 130)  # a 9-point character over the plot area (tick labels and y label take ~130 px)
    rows, out = [], []
    for text, x, colour in labels:
        fraction = ((math.log(x) if log else x) - lo) / (hi - lo) if hi > lo else 0.5
        extent = (len(text) + 1) * char
        right = fraction + extent <= 1.0
        span = (fraction, fraction + extent) if right else (fraction - extent, fraction)
        row = next((r for r, taken in enumerate(rows) if all(span[1] <= a or b <= span[0] for a, b in taken)), len(rows))
        if row == len(rows):
            rows.append([])
        rows[row].append(span)
        out.append(f"set label {gq(text)} at {x:.10g}, graph 1 {'left' if right else 'right'} "
                   f"offset {0.4 if right else -0.4},{0.7 + 1.1 * row:.2f} font ',9' textcolor rgb {gq(colour)} noenhanced")
    out += [f"set tmargin {1.1 * len(rows) + above:.1f}", f"set title offset 0,{1.1 * len(rows):.1f}"]
    return out


def bars_text(ensembles):
    """What the error bars are: 95 % bootstrap intervals of the mean over each ensemble's seeds."""
    counts = [(e.get("name"), e.get("members")) for e in ensembles]
    if len({n for _, n in counts}) == 1:
        return f"means and 95 % bootstrap intervals, n = {counts[0][1]} seeds"
    return "means and 95 % bootstrap intervals, " + ", ".join(f"{name} n = {n}" for name, n in counts) + " seeds"


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
    clauses, setup, xs, floors, labels = [], [], [], [], []
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
        setup += boundary_marks(ensemble, colour, plot.cairo, labels)
    if not clauses:
        return None
    setup += boundary_labels(labels, xs, True, 820)
    setup += ["set logscale xy", x_range(xs, True), phi_tics(min(xs), max(xs)),
              f"set yrange [{min(floors):.6g}:*]", "set format y '10^{%L}'", "set samples 2000",
              "set xlabel 'φ'", "set ylabel 'P_y  [F_0/a^2]'", key_below(clauses),
              "set grid", f"set title {gq('Compression curves and power laws per regime: ' + bars_text(ensembles))}"]
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
            labels = []
            body = ["reset", "unset object", "unset arrow", "unset label"]
            body += boundary_marks(ensemble, "#555555", plot.cairo, labels)
            body += boundary_labels(labels, xs, True, 600, above=3.4)
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
    body = f"set multiplot layout {rows},{columns} title {gq('Rupture rates by mode (positive values): ' + bars_text(ensembles))}\n" + \
        "\n".join(panels) + "\nunset multiplot"
    return plot.draw("rupture_rates.png", body, 600 * columns, 520 * rows + 40)


def figure_contacts(plot, ensembles):
    clauses, setup, xs, labels = [], [], [], []
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
            setup += boundary_marks(ensemble, colour, plot.cairo, labels)
    if not clauses:
        return None
    setup += boundary_labels(labels, xs, False, 760)
    setup += [x_range(xs, False), "set grid", "set xlabel 'φ'", "set ylabel 'contact number z'",
              key_below(clauses), f"set title {gq('Contact number: ' + bars_text(ensembles))}"]
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
    setup, labels = [], []
    for i, ensemble in enumerate(ensembles):
        if any(title.startswith(ensemble["name"] + " ") for _, _, title, _, _ in series):
            setup += boundary_marks(ensemble, COLOURS[i % len(COLOURS)], plot.cairo, labels)
    setup += boundary_labels(labels, xs, True, 760, above=3.3)  # a title of two lines
    setup += ["set logscale x", x_range(xs, True), phi_tics(min(xs), max(xs)), "set grid", "set xlabel 'φ (interval midpoint)'",
              "set ylabel 'dE / d ln φ  [F_0 a]'", key_below(clauses),
              f"set title {gq('Energy increments per d ln φ, stored (solid) and dissipated (dashed)')}.\"\\n\".{gq(bars_text(ensembles))}"]
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
             f"set title {gq('Length ξ^{(0.5)} against φ and its power law: ' + bars_text(ensembles))}"]
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
