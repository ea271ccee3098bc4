"""The report itself: the Markdown page (what was run, the observables, the section "Against the
paper", the rows and intervals of each ensemble, the figures, the notes) and the comparison with
the paper as JSON beside it."""
import json
import os
import tempfile

from .analysis import (FORMAT, PHI_TARGETS, REGIME_NAMES, REGIMES, as_dict, as_list, finite, fit_in, fit_of,
                       intervals_of, phi_of, row_near, rows_of, value_of)
from .comparison import comparison
from .figures import (Plotter, draw_snapshots, figure_compression, figure_contacts, figure_energy, figure_ruptures,
                      figure_xi)
from .members import PAPER_SAMPLES, PAPER_SEED, find_study
from .paper import PAPER_CONTEXT, short_model, verdict_text
from .text import BOOTSTRAP, DASH, cell, est, missing, num, seeds_of, seeds_text, table

# The repository: the report links docs/model.md when it is written inside it.
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


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



def comparison_table(entries):
    header = ["observable", "bond", "published", "model [95 % interval]", "seeds", "φ range", "verdict", "note"]
    lines = [[e["observable"], e["ensemble"], e["published"], e["model_text"],
              str(e["seeds"]) if e["seeds"] is not None else DASH, e.get("phi_range") or DASH, verdict_text(e),
              e.get("note") or ""] for e in entries]
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
        "compression": "Figure 1. P_y(φ) of each ensemble on log-log axes, with the 95 % intervals as error bars "
                       "(percentile bootstrap of the mean over the seeds, n in the title); lines: P_y = C φ^λ fitted in each regime, over its φ range (solid elastic, dashed "
                       "single-mode plastic, dash-dot multi-mode plastic; dotted: all trusted rows, drawn only "
                       "when no regime has a fit); vertical dashed lines: regime boundaries, shaded over their "
                       "intervals, labelled above the frame. " + open_note,
        "ruptures": "Figure 2. Rupture rates by mode against the interval midpoint φ_mid, one panel per ensemble; "
                    "only positive values appear on the log axis. Error bars: 95 % intervals (percentile "
                    "bootstrap of the mean over the seeds). Vertical dashed lines: regime boundaries. "
                    + open_interval_note,
        "contacts": "Figure 3. Contact number against φ, ensemble means with 95 % intervals (percentile bootstrap "
                    "over the seeds). " + open_note,
        "energy": "Figure 4. Stored (solid) and dissipated (dashed) energy per d ln φ against φ_mid; error bars: 95 % "
                  "intervals (percentile bootstrap of the mean over the seeds). "
                  + open_interval_note,
        "xi": "Figure 5. The length ξ^(0.5) against φ on log-log axes with its power-law fit over its φ range; error "
              "bars: 95 % intervals (percentile bootstrap of the mean over the seeds).",
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
