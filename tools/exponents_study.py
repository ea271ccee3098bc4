#!/usr/bin/env python3
"""The published exponents against wall speed and box: lambda_II and lambda_III fitted over the
paper's own phi ranges to the ensemble mean P_y(phi) of every ensemble of the quasi-static study
(tools/quasistatic_study.py: its gel families, variants, cache and committed results), with 95 %
percentile-bootstrap intervals over seeds, and the mean P_y at a few targets. Writes
docs/exponents.md; runs nothing itself:

    python3 tools/quasistatic_study.py --only small-bond1 --variant quasistatic-walls0.5x   # runs
    python3 tools/exponents_study.py                                                        # report

The paper's ranges (Seto et al., J. Rheol. 57, 1347, 2013): regime II 0.2 < phi < 0.31 for bond 1
and 0.2 < phi < 0.42 for bond 2, regime III phi >= 0.34 (bond 1) and phi >= 0.46 (bond 2);
published lambda_II = 5.8 +- 0.5 (bond 1), 5.8 +- 0.4 (bond 2), lambda_III = 4.3 +- 0.2 and
5.8 +- 0.4. Nothing here is fitted towards those numbers: they are printed beside the model's.
"""
import argparse
import math
import os
import random
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import quasistatic_study as qs  # noqa: E402
import accuracy_study as acc  # noqa: E402

RANGES = {  # bond: (regime II range, regime III lower bound)
    "bond1": ((0.2, 0.31), 0.34),
    "bond2": ((0.2, 0.42), 0.46),
}
PUBLISHED = {"bond1": ("5.8 ± 0.5", "4.3 ± 0.2"), "bond2": ("5.8 ± 0.4", "5.8 ± 0.4")}
SHOWN_PHI = (0.19, 0.25, 0.34, 0.50, 0.74)


def targets_in(runs, low, high):
    rows = min(len(r["rows"]) for r in runs)
    return [k for k in range(1, rows) if low < acc.mean([r["rows"][k]["phi"] for r in runs]) < high]


def interval(runs, ks, rng):
    value = acc.fit_lambda(runs, ks)
    if len(runs) < qs.MIN_SEEDS_FOR_INTERVAL:
        return value, float("nan"), float("nan")
    samples = sorted(x for x in (acc.fit_lambda([rng.choice(runs) for _ in runs], ks)
                                 for _ in range(qs.BOOTSTRAP_SAMPLES)) if not math.isnan(x))
    return value, samples[int(0.025 * len(samples))], samples[int(0.975 * len(samples)) - 1]


# The local exponent: where along phi does lambda differ between boxes? It is the slope of
# log P_y between consecutive targets of the ensemble mean, up to LOCAL_MAX_PHI (regime III is
# one straight line beyond), for the variants that answer the question: the method, the
# reference protocol and the slower walls.
LOCAL_VARIANTS = ("quasistatic", "paper", "quasistatic-walls0.5x", "quasistatic-walls0.25x")
LOCAL_MAX_PHI = 0.47


def local_slope(runs, k):
    p0, p1 = (acc.mean([r["rows"][j]["P"] for r in runs]) for j in (k, k + 1))
    phi0, phi1 = (acc.mean([r["rows"][j]["phi"] for r in runs]) for j in (k, k + 1))
    if p0 <= 0 or p1 <= 0:
        return float("nan")
    return (math.log(p1) - math.log(p0)) / (math.log(phi1) - math.log(phi0))


def local_exponents(runs, rng):
    """[(phi_k, phi_k+1, slope, low, high)] of the ensemble mean, k >= 1."""
    rows = min(len(r["rows"]) for r in runs)
    out = []
    for k in range(1, rows - 1):
        phi0, phi1 = (acc.mean([r["rows"][j]["phi"] for r in runs]) for j in (k, k + 1))
        if phi1 > LOCAL_MAX_PHI:
            break
        value, low, high = local_slope(runs, k), float("nan"), float("nan")
        if len(runs) >= qs.MIN_SEEDS_FOR_INTERVAL:
            samples = sorted(x for x in (local_slope([rng.choice(runs) for _ in runs], k)
                                         for _ in range(qs.BOOTSTRAP_SAMPLES)) if not math.isnan(x))
            low, high = samples[int(0.025 * len(samples))], samples[int(0.975 * len(samples)) - 1]
        out.append((phi0, phi1, value, low, high))
    return out


def plot_local(bond, curves, pictures):
    lines = []
    for (family, variant, seeds), rows in curves:
        data = os.path.join(pictures, f"local-{bond}-{family}-{variant}.dat")
        with open(data, "w") as f:
            f.write("# phi_mid slope low high (d ln P_y / d ln phi between consecutive targets, 95 % interval)\n")
            for phi0, phi1, value, low, high in rows:
                if math.isnan(value):
                    continue
                low = value if math.isnan(low) else low
                high = value if math.isnan(high) else high
                f.write(f"{math.sqrt(phi0 * phi1):.6g} {value:.6g} {low:.6g} {high:.6g}\n")
        dash = 1 if family == "paper" else 2
        lines.append(f"'{os.path.basename(data)}' using 1:2:3:4 with yerrorlines lw 2 dt {dash} pt 7 "
                     f"title '{family} box, {variant} ({seeds} seeds)'")
    if not lines:
        return None
    name = f"local-{bond}.png"
    low, high = RANGES[bond][0]
    qs.gnuplot("set terminal pngcairo size 760,520 font ',11'\n"
               f"set output '{name}'\nset xlabel 'φ (geometric mean of two consecutive targets)'\n"
               "set ylabel 'd ln P_y / d ln φ'\nset key top right\nset grid\n"
               f"set object 1 rect from {low},graph 0 to {high},graph 1 fc rgb '#eeeeee' behind\n"
               f"set label 1 \"the paper's regime II\" at first {low + 0.005:.3f},graph 0.95\n"
               "set xrange [0.15:0.47]\nset yrange [0:24]\n"
               "plot 5.8 with lines lc 'black' dt 3 title 'published λ_{II} = 5.8', " + ", ".join(lines) + "\n",
               pictures)
    return name


def show(value, low, high):
    if math.isnan(value):
        return "–"
    return f"{value:.2f}" + ("" if math.isnan(low) else f" [{low:.2f}, {high:.2f}]")


def finished_runs(work, committed, gel, variant):
    runs = [c for c in (qs.cached(work, gel, variant, seed) or committed.get((gel, variant, seed))
                        for seed in range(1, 65)) if c]
    return [r for r in runs if r["rows"] and r["rows"][-1]["k"] == len(r["rows"]) - 1]


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--work", default=os.path.expanduser("~/.cache/gel-studies/quasistatic"))
    parser.add_argument("--out", default=os.path.join(qs.ROOT, "docs", "exponents.md"))
    args = parser.parse_args()
    rng = random.Random(20261207)
    committed = qs.committed_runs()
    pictures = os.path.join(os.path.dirname(args.out), "exponents")
    os.makedirs(pictures, exist_ok=True)
    out = ["# The published exponents against wall speed and box size\n",
           f"Generated by `python3 tools/exponents_study.py` on {time.strftime('%Y-%m-%d')} from the runs of the "
           "quasi-static study (`tools/quasistatic_study.py`, rows in "
           "[quasistatic/results.json](quasistatic/results.json)). Do not edit by hand.\n",
           "λ is the slope of log P_y against log φ of the ensemble mean, fitted over the paper's own ranges "
           "(regime II: 0.2 < φ < 0.31 for bond 1, 0.2 < φ < 0.42 for bond 2; regime III: φ ≥ 0.34 and "
           "φ ≥ 0.46), with the 95 % percentile-bootstrap interval over seeds (none below "
           f"{qs.MIN_SEEDS_FOR_INTERVAL} seeds). The published values (Seto et al. 2013) are printed beside "
           "them, never fitted towards. Families: `small` is 1408 particles in 150 × 250 a, `paper` the "
           "paper's 5760 in 300 × 500 a, `paper4x` 23 040 in 600 × 1000 a (the paper's φ_0 and floc size). "
           "Variants: docs/accuracy.md \"The settings\".\n"]
    notes = os.path.join(qs.ROOT, "docs", "exponents_notes.md")
    if os.path.exists(notes):
        out.append("*The reading below is written by hand (docs/exponents_notes.md); the tables after it are "
                   "generated.*\n")
        out.append(open(notes).read().strip() + "\n")
    for bond in ("bond1", "bond2"):
        (low, high), regime3 = RANGES[bond]
        out.append(f"## {bond}\n")
        out.append(f"Published: λ_II = {PUBLISHED[bond][0]}, λ_III = {PUBLISHED[bond][1]}.\n")
        out.append("| family | variant | seeds | λ_II [95 %] | λ_III [95 %] | " +
                   " | ".join(f"P_y(φ ≈ {phi:.2f})" for phi in SHOWN_PHI) + " |")
        out.append("|---|---|---:|---|---|" + "---:|" * len(SHOWN_PHI))
        for gel in qs.GELS:
            if not gel.endswith(bond):
                continue
            for variant in qs.VARIANTS:
                runs = finished_runs(args.work, committed, gel, variant)
                if len(runs) < 2:
                    continue
                rows = min(len(r["rows"]) for r in runs)
                lam2 = interval(runs, targets_in(runs, low, high), rng)
                lam3 = interval(runs, targets_in(runs, regime3, 1.0), rng)
                cells = []
                for phi in SHOWN_PHI:
                    k = min(range(1, rows), key=lambda k: abs(acc.mean([r["rows"][k]["phi"] for r in runs]) - phi))
                    cells.append(f"{acc.mean([r['rows'][k]['P'] for r in runs]):.3g}")
                out.append(f"| {gel.split('-')[0]} | {variant} | {len(runs)} | {show(*lam2)} | {show(*lam3)} | " +
                           " | ".join(cells) + " |")
        out.append("")
        out.append(f"### {bond}: the local exponent\n")
        out.append("d ln P_y / d ln φ of the ensemble mean between consecutive targets (its 95 % interval: "
                   "seeds resampled), where λ_II's difference between the boxes lives. Each row is one pair "
                   "of targets k → k+1 (the boxes' targets differ a little, as their φ_0 do); the picture below shows the same.\n")
        curves = []
        for gel in qs.GELS:
            if not gel.endswith(bond):
                continue
            for variant in LOCAL_VARIANTS:
                runs = finished_runs(args.work, committed, gel, variant)
                if len(runs) < 2:
                    continue
                curves.append(((gel.split("-")[0], variant, len(runs)), local_exponents(runs, rng)))
        if curves:
            # One row per pair of targets, one column per ensemble; the families' targets differ a
            # little (their phi_0 differ), so each family's phi pair is shown once.
            families = list(dict.fromkeys(family for (family, _, _), _ in curves))
            pairs = max(len(rows) for _, rows in curves)
            out.append("| k → k+1 | " + " | ".join(f"φ, {family} box" for family in families) + " | " +
                       " | ".join(f"{family}, {variant} ({seeds})" for (family, variant, seeds), _ in curves) + " |")
            out.append("|---|" + "---|" * len(families) + "---|" * len(curves))
            for i in range(pairs):
                phis = []
                for family in families:
                    rows = next(rows for (f, _, _), rows in curves if f == family)
                    phis.append(f"{rows[i][0]:.3f} → {rows[i][1]:.3f}" if i < len(rows) else "–")
                cells = [show(*rows[i][2:]) if i < len(rows) else "–" for _, rows in curves]
                out.append(f"| {i + 1} → {i + 2} | " + " | ".join(phis) + " | " + " | ".join(cells) + " |")
            picture = plot_local(bond, curves, pictures)
            if picture:
                out.append(f"\n![local exponent, {bond}](exponents/{picture})")
        out.append("")
    with open(args.out, "w") as f:
        f.write("\n".join(out) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
