"""The published values of Seto et al. (2013) and the rules that hold the model's numbers against
them: the band of each published value, one comparison entry with its verdict, and how a verdict
reads. Nothing here feeds back into the model or the study analysis: the model's numbers are
reported as they come."""
import re

from .analysis import bounds_of, finite, value_of
from .text import DASH, num

VERDICTS = {"inside": "inside the published band", "outside": "outside", "not comparable": "not comparable"}
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
    "eight of the same 1408-particle bond-1 gels (docs/reference_code.md, \"As ensembles\"), gives a λ_II inside "
    "the intervals of the product's `paper` and `quasistatic` runs of those gels, and all three intervals hold the "
    "published 5.8: on that box the codes agree, so the higher λ_II at the paper's size is not a difference between "
    "the product and the paper's code. On the first two 1408-particle bond-2 gels it also agrees with the "
    "product's `paper` at every row (0.86–1.25×), and gives λ_II 5.7 against 5.4 (`paper`) and 6.3 "
    "(`quasistatic`) on the same gels (two seeds, no interval yet). Walls at half and a quarter of the paper's speed (8 seeds each, small bond-1 "
    "box) give λ_II 5.37 and 5.17 against 5.19 at the paper's speed: the slow-compression limit is reached at half "
    "the speed, and it raises P_y by up to 17 % at φ 0.19–0.37 without moving λ_II. The box moves λ_II by 2–3 units, "
    "and not through its lowest rows alone: between φ ≈ 0.21 and 0.34 the paper box's curve is steeper at every pair "
    "of targets, in both protocols (local exponent 6.3–8.7 against the small box's 4.1–7.1), and from φ ≈ 0.34 on the "
    "two boxes agree (docs/exponents.md). So the measured reason for λ_II at the paper's size is the box: the model "
    "reproduces the published 5.8 in the 1408-particle box and gives 7.4–8.2 in the paper's. The 4× box (23 040 "
    "particles, 600 × 1000 a, 3 seeds so far, about 70 min of CPU each) gives λ_II 10.3 (the seeds alone 9.9, 10.7 and "
    "10.7): all three of its seeds lie below all four paper-box seeds at φ 0.214–0.313 (P_y 3.8·10⁻⁴ against 7.3·10⁻⁴ "
    "at 0.235), while at φ 0.74 the two boxes agree (0.393 and 0.403). So P_y in regime II keeps falling as the box "
    "grows and λ_II keeps rising; the paper's box is not yet the large-box value, and the published 5.8 is what the "
    "smallest box gives (three seeds, no interval yet). The paper's own code "
    "at the paper's size reached φ 0.259 on one gel (seed 1, docs/reference_code.md). There it agrees with the "
    "product's `paper` at every row (its own rows all stopped at the wait cap), but at φ 0.214, the lowest row of the paper's "
    "λ_II range, its P is 1.7× the relaxed value, while at 0.235 and 0.259 all three agree. A raised lowest row flattens "
    "the fit, so the published protocol's λ_II at the paper's size would come out below the relaxed 7.3–8.2. That is "
    "one seed and three of the range's five rows, not yet a measurement of its λ_II.")


def bond_of(name):
    """The paper's bond (1 or 2) an ensemble stands for, from its name (bond1, paper-bond2, ...)."""
    match = re.search(r"bond[-_ ]?([12])(?!\d)", str(name))
    return int(match.group(1)) if match else None


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


def bending_entry():
    return entry("three-point bending threshold (validation)", "bond1", "0.22 F0 recovers, 0.23 F0 deforms plastically",
                 (0.22, 0.23), None, verdict="inside", model_text="between 0.22 and 0.23 F0",
                 note="reproduced by test ModelPins.BendingThresholdLiesBetween022And023 (a chain of 11 particles, "
                      "bond 1; not a study quantity)")


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
