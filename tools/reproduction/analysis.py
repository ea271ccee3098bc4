"""The study analysis (format gel.study-analysis.v1) as this report reads it: loading and
checking the JSON, and the accessors for its rows, intervals, fits and regime boundaries. Every
accessor tolerates a missing or malformed field (None or an empty list), so the report can say
what is missing instead of failing."""
import json
import math

FORMAT = "gel.study-analysis.v1"
REGIMES = (("elastic", "elastic"), ("single_mode_plastic", "single-mode plastic"),
           ("multi_mode_plastic", "multi-mode plastic"))
REGIME_NAMES = {"elastic": "elastic", "single-mode-plastic": "single-mode plastic",
                "multi-mode-plastic": "multi-mode plastic"}
PHI_TARGETS = (0.3, 0.5, 0.7)
# A row stands for "P_y at phi = 0.5" only when it is within this factor of 0.5 (the targets of
# a compression are a geometric series with a ratio of about 1.1, so one row is always closer).
PHI_TOLERANCE = 1.1


class InputError(Exception):
    """The input is not a study analysis this tool reads: exit code 2."""


def finite(x):
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


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


def as_list(x):
    return x if isinstance(x, list) else []


def as_dict(x):
    return x if isinstance(x, dict) else {}


def phi_of(row):
    """phi of a row: an Estimate in rows, a bare number in excluded rows and xi rows."""
    return value_of(row.get("phi")) if isinstance(row, dict) else None


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
    for source in (rows_of(ensemble), intervals_of(ensemble)):
        for item in source:
            regime = keys.get(item.get("regime"))
            if regime and regime not in first:
                first[regime] = int(item["k"])
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
