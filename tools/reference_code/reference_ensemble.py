#!/usr/bin/python3
"""The paper's own code against the product on the same gels, as ensembles: per target, the
ratio of the ensemble-mean P of the reference code to the product's `paper` and `quasistatic`
runs with a 95 % bootstrap interval over seeds, the contact number and the ruptures by mode, and
lambda_II over the paper's range, each with the seeds behind it.

  /usr/bin/python3 tools/reference_code/reference_ensemble.py [--refruns /work/refruns]
      [--family small] [--bond 1] [--update-doc]

With --update-doc the tables replace the text between the markers
`<!-- reference_ensemble <family>-bond<b> begin -->` and `... end -->` in docs/reference_code.md
(the markers are added at the end of its "Measured" section the first time); without it they
are printed.

Reads only cached runs: REFRUNS/<family>-bond<b>/seed_<s>/curve.json (run_reference.sh) and the
product's committed rows of the same gels (docs/quasistatic/results.json). The seeds are paired:
the gels are the same, so a bootstrap sample draws seeds, not runs, and takes each drawn seed's
reference and product rows together. A target is "differs" when the interval of the ratio of
means excludes 1; one target in twenty may do so by chance. No interval is given for fewer than
4 seeds. The reference code's rows at phi < 0.31 mostly stop at its wait cap (docs/reference_code.md):
the `eq.` columns count the seeds whose row is equilibrated.
"""
import argparse
import glob
import json
import math
import os
import random
import sys

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import quasistatic_study as qs  # noqa: E402
import accuracy_study as acc  # noqa: E402
import exponents_study  # noqa: E402

# The paper's regime II ranges (Seto et al. 2013), over which lambda_II is fitted.
REGIME_II = {1: (0.2, 0.31), 2: (0.2, 0.42)}
PUBLISHED_LAMBDA_II = {1: "5.8 ± 0.5", 2: "5.8 ± 0.4"}


def reference_runs(refruns, family, bond):
    runs = {}
    for path in glob.glob(os.path.join(refruns, f"{family}-bond{bond}", "seed_*", "curve.json")):
        curve = json.load(open(path))
        seed = int(path.split("seed_")[1].split("/")[0])
        runs[seed] = {"seed": seed, "rows": curve["rows"], "complete": curve.get("complete", False)}
    return runs


def product_runs(family, bond, fidelity):
    return {seed: run for (gel, variant, seed), run in qs.committed_runs().items()
            if gel == f"{family}-bond{bond}" and variant == fidelity}


def paired_ratio(pairs, rng):
    """Ratio of means over seeds of (a, b) pairs, with a paired 95 % bootstrap interval."""
    def ratio(sample):
        den = acc.mean([b for _, b in sample])
        return acc.mean([a for a, _ in sample]) / den if den > 0 else float("nan")
    value = ratio(pairs)
    if len(pairs) < qs.MIN_SEEDS_FOR_INTERVAL:
        return value, float("nan"), float("nan")
    samples = sorted(x for x in (ratio([rng.choice(pairs) for _ in pairs]) for _ in range(qs.BOOTSTRAP_SAMPLES))
                     if not math.isnan(x))
    return value, samples[int(0.025 * len(samples))], samples[int(0.975 * len(samples)) - 1]


def show(value, low, high, digits=3):
    if math.isnan(value):
        return "–"
    text = f"{value:.{digits}f}"
    return text if math.isnan(low) else f"{text} [{low:.{digits}f}, {high:.{digits}f}]"


def verdict(low, high):
    if math.isnan(low):
        return "too few seeds"
    return "differs" if (low > 1 or high < 1) else "agrees"


def report(args):
    rng = random.Random(20261207)
    ref = reference_runs(args.refruns, args.family, args.bond)
    products = {f: product_runs(args.family, args.bond, f) for f in ("paper", "quasistatic")}
    seeds = sorted(s for s in ref if all(s in products[f] for f in products))
    if not seeds:
        sys.exit(f"no seed of {args.family}-bond{args.bond} has both a cached reference run in {args.refruns} "
                 "and committed product runs: nothing to compare (run_reference.sh makes the former)")
    targets = min(min(len(ref[s]["rows"]) for s in seeds),
                  min(len(products[f][s]["rows"]) for f in products for s in seeds))
    out = [f"### {args.family}-bond{args.bond}: reference code (`491cca3`) against the product, "
           f"{len(seeds)} seeds ({', '.join(map(str, seeds))}), same gels\n",
           "| k | φ (ref) | P ref [F0/a²] | eq. ref | ref / `paper` (95 %) | | ref / `quasistatic` (95 %) | | "
           "z ref − `paper` | normal breaks ref / `paper` | rolling ref / `paper` |",
           "|" + "---|" * 11]
    outside = {f: 0 for f in products}
    compared = 0
    for k in range(1, targets):
        rows = [ref[s]["rows"][k] for s in seeds]
        cells = []
        for f in ("paper", "quasistatic"):
            pairs = [(ref[s]["rows"][k]["P"], products[f][s]["rows"][k]["P"]) for s in seeds]
            value, low, high = paired_ratio(pairs, rng)
            v = verdict(low, high)
            outside[f] += v == "differs"
            cells += [show(value, low, high), v]
        compared += 1
        paper_rows = [products["paper"][s]["rows"][k] for s in seeds]
        dz = acc.mean([r["contact_number"] for r in rows]) - acc.mean([r["contact_number"] for r in paper_rows])

        def counts(cause):
            a = acc.mean([r["ruptures"][cause] for r in rows])
            b = acc.mean([r["ruptures"][cause] for r in paper_rows])
            return f"{a:.0f} / {b:.0f}"
        out.append(f"| {k} | {acc.mean([r['phi'] for r in rows]):.3f} | {acc.mean([r['P'] for r in rows]):.3g} | "
                   f"{sum(1 for r in rows if r.get('equilibrated'))}/{len(rows)} | {cells[0]} | {cells[1]} | "
                   f"{cells[2]} | {cells[3]} | {dz:+.3f} | {counts('normal')} | {counts('rolling')} |")
    out.append("")
    out.append(f"Targets whose interval excludes 1 (of {compared}): against `paper` {outside['paper']}, "
               f"against `quasistatic` {outside['quasistatic']}; by chance about {compared / 20:.1f}.\n")
    low, high = REGIME_II[args.bond]
    rows_of = {"reference code": [ref[s] for s in seeds]}
    rows_of.update({f"`{f}`": [products[f][s] for s in seeds] for f in products})
    ks = [k for k in range(1, targets)
          if low < acc.mean([r["rows"][k]["phi"] for r in rows_of["`paper`"]]) < high]
    out.append(f"λ_II, the ensemble mean P fitted over {low} < φ < {high} (targets {ks[0]}–{ks[-1]}), "
               f"seed bootstrap; published {PUBLISHED_LAMBDA_II[args.bond]}:\n")
    out.append("| ensemble | seeds | λ_II (95 %) |")
    out.append("|---|---:|---|")
    for name, runs in rows_of.items():
        out.append(f"| {name} | {len(runs)} | {show(*exponents_study.interval(runs, ks, rng), digits=2)} |")
    out.append("")
    return "\n".join(out) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--refruns", default="/work/refruns")
    ap.add_argument("--family", default="small")
    ap.add_argument("--bond", type=int, default=1, choices=(1, 2))
    ap.add_argument("--update-doc", action="store_true", help="write the tables into docs/reference_code.md")
    args = ap.parse_args()
    text = report(args)
    if not args.update_doc:
        sys.stdout.write(text)
        return
    path = os.path.join(qs.ROOT, "docs", "reference_code.md")
    doc = open(path).read()
    begin = f"<!-- reference_ensemble {args.family}-bond{args.bond} begin -->"
    end = f"<!-- reference_ensemble {args.family}-bond{args.bond} end -->"
    block = f"{begin}\n{text}{end}"
    if begin in doc:
        doc = doc[:doc.index(begin)] + block + doc[doc.index(end) + len(end):]
    else:
        anchor = "### Not done"
        if anchor not in doc:
            sys.exit(f"{path} has neither the markers nor a '{anchor}' heading to put them before")
        doc = doc.replace(anchor, block + "\n\n" + anchor, 1)
    with open(path, "w") as f:
        f.write(doc)
    print(f"wrote the {args.family}-bond{args.bond} tables into {path}")


if __name__ == "__main__":
    main()
