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
# The work is done by the package tools/reproduction/ (one module per concept, listed in its __init__.py).
import argparse
import os
import sys

from reproduction.analysis import FORMAT, InputError, load
from reproduction.report import ROOT, write_report


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
