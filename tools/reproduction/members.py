"""The members of an ensemble read from a `gelsim study` directory (curve.json, structure.json per
seed), and the tools the comparison with the paper computes on them: the ensemble-mean row, the
trusted rows, a log-log slope, rows picked by their φ, and the seeded bootstrap over members."""
import json
import math
import os
import random

from .analysis import as_dict, as_list, finite
from .text import num

# The bootstrap of the analyses below: resample members with replacement, recompute, this many
# times, from random.Random seeded with this text, the ensemble's name and the quantity (so the
# report is the same on every run and no quantity's interval depends on another's).
PAPER_SAMPLES = 1000
PAPER_SEED = "reproduction_report.v1"


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
