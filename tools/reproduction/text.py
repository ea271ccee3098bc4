"""Numbers and Markdown tables as the report prints them: 3 significant digits, an Estimate as
"value [lo, hi]" (or why it has no interval), "—" for a missing value with its reason."""
from .analysis import bounds_of, finite, value_of, as_list

DASH = "—"
# The study's bootstrap_samples: the resamples behind an Estimate that does not name them.
BOOTSTRAP = {"samples": None}


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


def seeds_text(seeds):
    seeds = [s for s in as_list(seeds) if finite(s)]
    if not seeds:
        return DASH
    seeds = [int(s) for s in seeds]
    if seeds == list(range(seeds[0], seeds[0] + len(seeds))) and len(seeds) > 2:
        return f"{seeds[0]}–{seeds[-1]}"
    return ", ".join(str(s) for s in seeds)
