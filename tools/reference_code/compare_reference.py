#!/usr/bin/python3
"""Tabulate cached reference-code runs (REFRUNS/<family>-bond<b>/seed_<s>/curve.json, written by
run_reference.sh) against the product's committed runs of the same gels
(docs/quasistatic/results.json: per-seed rows of the `paper` and `quasistatic` fidelities).

  /usr/bin/python3 tools/reference_code/compare_reference.py [--refruns /work/refruns] [--family small]
      [--bond 1] [--ks 1,3,5,8,12,17] [--markdown]

The product's gel of a seed is the same gel only if its k = 0 phi equals the converter's phi_0
(both are N pi / (L_x gap) with the walls touching the lowest and highest particle); the table
says so per seed.
"""
import argparse
import glob
import json
import os

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def fmt(v, f="{:.4g}"):
    return "–" if v is None else f.format(v)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--refruns", default="/work/refruns")
    ap.add_argument("--family", default="small")
    ap.add_argument("--bond", type=int, default=1)
    ap.add_argument("--ks", default="1,3,5,8,12,17")
    ap.add_argument("--version", default="491cca3", help="491cca3 (REFRUNS/<family>-bond<b>) or ac47e98 (…-ac47e98)")
    ap.add_argument("--results", default=os.path.join(ROOT, "docs", "quasistatic", "results.json"))
    args = ap.parse_args()
    ks = [int(k) for k in args.ks.split(",")]
    fam = f"{args.family}-bond{args.bond}"
    results = json.load(open(args.results)).get(fam, {})
    product = {v: {e["seed"]: e["rows"] for e in results.get(v, [])} for v in ("paper", "quasistatic")}
    ref_dir = fam if args.version == "491cca3" else f"{fam}-{args.version}"
    paths = sorted(glob.glob(os.path.join(args.refruns, ref_dir, "seed_*", "curve.json")),
                   key=lambda p: int(p.split("seed_")[1].split("/")[0]))
    print(f"| seed | wall s | CPU s | rows | same gel | k | target φ | ref φ | ref P | ref eq | "
          f"paper φ | paper P | paper eq | quasistatic P | ref/paper | ref/quasistatic |")
    print("|" + "---|" * 16)
    for p in paths:
        c = json.load(open(p))
        seed = int(p.split("seed_")[1].split("/")[0])
        meta = json.load(open(os.path.join(os.path.dirname(p), "run", "meta.json")))
        rows = {r["k"]: r for r in c["rows"]}
        pp = {r["k"]: r for r in product["paper"].get(seed, [])}
        pq = {r["k"]: r for r in product["quasistatic"].get(seed, [])}
        same = "–"
        if 0 in pp:
            same = "yes" if abs(pp[0]["phi"] - meta["phi0"]) < 1e-12 else f"NO ({pp[0]['phi']:.6g})"
        first = True
        for k in ks:
            r = rows.get(k)
            a, q = pp.get(k), pq.get(k)
            ratio = (r["P"] / a["P"]) if (r and a and a["P"]) else None
            ratio_q = (r["P"] / q["P"]) if (r and q and q["P"]) else None
            head = (f"| {seed} | {fmt(c.get('wall_seconds'), '{:.0f}')} | {fmt(c.get('cpu_seconds'), '{:.0f}')} | "
                    f"{len(c['rows'])}{'' if c.get('complete') else ' (stopped)'} | {same} ") if first \
                else "| | | | | "
            first = False
            print(head + f"| {k} | {fmt(meta['targets'][k - 1] if k - 1 < len(meta['targets']) else None, '{:.4f}')} | "
                  f"{fmt(r and r['phi'], '{:.4f}')} | {fmt(r and r['P'])} | "
                  f"{'–' if not r or 'equilibrated' not in r else ('yes' if r['equilibrated'] else 'cap')} | "
                  f"{fmt(a and a['phi'], '{:.4f}')} | {fmt(a and a['P'])} | "
                  f"{'–' if not a else ('yes' if a.get('equilibrated') else 'cap')} | {fmt(q and q['P'])} | "
                  f"{fmt(ratio, '{:.3f}')} | {fmt(ratio_q, '{:.3f}')} |")
    summary(args, ks, paths, product)


def summary(args, ks, paths, product):
    """Per target: means over the seeds run, with the product's own quasistatic/paper ratio on the
    same gels as a yardstick for how much one gel's P moves between two valid methods."""
    import math
    print()
    print("| k | seeds | mean ref φ − target | mean ref P | mean paper P | mean quasistatic P | "
          "ref/paper (geo. mean, min–max) | same, ref moved back to the target with P ~ φ^4 | "
          "quasistatic/paper (geo. mean, min–max) |")
    print("|" + "---|" * 9)
    for k in ks:
        ref, pap, qs, dphi, r1, r2, r3 = [], [], [], [], [], [], []
        for p in paths:
            c = json.load(open(p))
            seed = int(p.split("seed_")[1].split("/")[0])
            rows = {r["k"]: r for r in c["rows"]}
            a = {r["k"]: r for r in product["paper"].get(seed, [])}.get(k)
            q = {r["k"]: r for r in product["quasistatic"].get(seed, [])}.get(k)
            r = rows.get(k)
            if not (r and a) or r["P"] <= 0 or a["P"] <= 0:
                continue
            ref.append(r["P"]); pap.append(a["P"])
            dphi.append(r["phi"] - r["target_phi"])
            r1.append(r["P"] / a["P"])
            # An estimate, not a measurement: the overshoot undone with a local exponent of 4.
            r3.append(r["P"] * (r["target_phi"] / r["phi"]) ** 4 / a["P"])
            if q and q["P"] > 0:     # the product's quasistatic P can be ~0 or < 0 before spanning
                qs.append(q["P"]); r2.append(q["P"] / a["P"])
        if not ref:
            continue
        g = lambda xs: math.exp(sum(math.log(x) for x in xs) / len(xs))
        m = lambda xs: sum(xs) / len(xs)
        qcol = f"{g(r2):.3f} ({min(r2):.2f}–{max(r2):.2f})" + ("" if len(r2) == len(r1) else f" [{len(r2)} seeds]")
        print(f"| {k} | {len(ref)} | {m(dphi):.4f} | {m(ref):.4g} | {m(pap):.4g} | "
              f"{(m(qs) if qs else float('nan')):.4g} | "
              f"{g(r1):.3f} ({min(r1):.2f}–{max(r1):.2f}) | {g(r3):.3f} | {qcol} |")


if __name__ == "__main__":
    main()
