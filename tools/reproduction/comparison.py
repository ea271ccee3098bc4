"""The comparison with the paper, observable by observable: each function gives the entries of one
published statement for one ensemble, from the study analysis and the ensemble's members."""
import math
import statistics

from .analysis import REGIMES, as_dict, finite, fit_in, fit_of, phi_of, row_near, rows_of
from .members import bootstrap, ks_in, load_members, loglog_slope, mean_of, rows_text, trusted_ks
from .paper import PAPER_BONDS, bending_entry, bond_of, entry, estimate_parts
from .text import DASH, est, num


class Ensemble:
    """What every comparison of one ensemble reads: the analysis's ensemble, its members (possibly
    none), the paper's values for its bond, and the bootstrap over its members."""

    def __init__(self, ensemble, members):
        self.ensemble, self.members = ensemble, members
        self.name, self.bond = ensemble["name"], bond_of(ensemble["name"])
        self.paper = PAPER_BONDS[self.bond]
        self.n = len(members)
        self.rows = rows_of(ensemble)
        self.ks = trusted_ks(members)
        self.regimes = as_dict(ensemble.get("regimes"))
        self.no_members = "no member curves (pass --study DIR, the `gelsim study` directory)" if not members else None

    def boot(self, stat, what, discrete=False):
        return bootstrap(self.members, stat, f"{self.name}:{what}", discrete)


def fractal_dimension(c):
    """D_f of the initial networks: compared with the band, never comparable (its fit range differs)."""
    ensemble, members, name = c.ensemble, c.members, c.name
    out = []
    # Initial networks: D_f.
    value, interval, seeds = estimate_parts(ensemble.get("fractal_dimension_initial"))
    options = next((m["structure_options"] for m in members if m.get("structure_options")), None) or {}
    rmin, rmax = options.get("fit_rmin"), options.get("fit_rmax")
    if finite(rmin) and finite(rmax):
        why = f"the model's C(r) is fitted over {rmin:g} < r/a < {rmax:g} (structure options), the paper's over " \
              "6 < r/a < 15; the archive keeps no configurations to refit over the paper's range"
    else:
        why = "the model's fit range of C(r) is not known here (no structure.json); the paper's is 6 < r/a < 15"
    inside = value is not None and 1.545 <= value <= 1.555
    out.append(entry("fractal dimension D_f of the initial networks", name,
                     "≈ 1.55 (C(r) a power law for 6 < r/a < 15)", (1.545, 1.555), value, interval, seeds,
                     comparable=False, reason=why,
                     note=None if value is None else f"read against the band alone it would be "
                     f"{'inside' if inside else 'outside'}"))
    return out


def contact_numbers(c):
    """The contact number of the initial network and of the last row."""
    name, rows = c.name, c.rows
    out = []
    # Contact number: from 2 to about 4.
    if rows:
        value, interval, seeds = estimate_parts(rows[0].get("contact_number"))
        out.append(entry("contact number, initial network", name, "2", (1.5, 2.5), value, interval, seeds,
                         phi_range=f"k = {int(rows[0]['k'])}, φ = {num(phi_of(rows[0]))}"))
        value, interval, seeds = estimate_parts(rows[-1].get("contact_number"))
        out.append(entry("contact number at the last row", name, "about 4 (at φ ≈ 0.74)", (3.5, 4.5), value,
                         interval, seeds, phi_range=f"k = {int(rows[-1]['k'])}, φ = {num(phi_of(rows[-1]))}"))
    return out


def span_of_p(c):
    """How many decades P_y spans from φ ≈ 0.16 to the last row."""
    members, name, n, no_members, boot = c.members, c.name, c.n, c.no_members, c.boot
    out = []
    # P_y spans about four decades from 0.16 to 0.74.
    if members:
        k16 = row_near([{"k": k, "phi": mean_of(members, k, "phi")} for k in range(len(members[0]["rows"]))], 0.16)
        k_last = len(members[0]["rows"]) - 1
    else:
        k16, k_last = None, None
    if k16 is not None and k16["k"] != k_last:
        k1 = k16["k"]

        def decades(draw):
            a, b = mean_of(draw, k1, "P"), mean_of(draw, k_last, "P")
            return math.log10(b / a) if a and b and a > 0 and b > 0 else None
        value = decades(members)
        spanning = [m for m in members if m["rows"][k1]["spans"]]
        span_value = decades(spanning) if spanning else None
        note = (f"mean P_y of all members at k = {k1} and k = {k_last}, as the study analysis's rows; "
                f"{len(spanning)} of {n} members span at k = {k1}")
        if span_value is not None and len(spanning) < n:
            note += f" (the spanning members alone: {num(span_value)} decades)"
        out.append(entry("decades of P_y from φ ≈ 0.16 to φ_max", name, "about 4 (φ ≈ 0.16 to 0.74)", (3.5, 4.5),
                         value, boot(decades, "decades"), n,
                         phi_range=f"φ {num(mean_of(members, k1, 'phi'))}–{num(mean_of(members, k_last, 'phi'))}",
                         note=note))
    else:
        out.append(entry("decades of P_y from φ ≈ 0.16 to φ_max", name, "about 4 (φ ≈ 0.16 to 0.74)", (3.5, 4.5),
                         reason=no_members or "no row near φ = 0.16"))
    return out


def dissipation_crossing(c):
    """Where the dissipated energy overtakes the stored one: the product's boundary, held against
    each member's crossing."""
    members, name, regimes = c.members, c.name, c.regimes
    out = []
    # Dissipated exceeds stored from phi ~ 0.2.
    value, interval, seeds = estimate_parts(regimes.get("elastic_to_plastic_phi"))
    upper = bool(regimes.get("elastic_to_plastic_at_first_trusted_row"))
    crossings = []
    for m in members:
        k = next((r["k"] for r in m["rows"][1:] if r["stored"] is not None and r["dissipated"] is not None
                  and r["dissipated"] >= r["stored"]), None)
        crossings.append((m["rows"][k - 1]["phi"], m["rows"][k]["phi"]) if k else None)
    band = (0.15, 0.25)
    reason, verdict, note = None, None, "the product's boundary (regime rule below), from the mean curve's trusted rows"
    if members and all(crossings):
        lo, hi = min(c[0] for c in crossings), max(c[1] for c in crossings)
        note += f"; per member the cumulative dissipated energy reaches the stored one between φ {num(lo)} and {num(hi)}"
        if band[0] <= lo and hi <= band[1]:
            verdict = "inside"
        elif hi < band[0] or lo > band[1]:
            verdict = "outside"
        else:
            verdict, reason = "not comparable", f"the rows do not resolve it: the crossing lies in ({num(lo)}, " \
                f"{num(hi)}], which straddles the band's edge; the rows the paper puts in its elastic regime " \
                f"(φ < 0.2) already dissipate more than they store in every member"
    elif upper and value is not None:
        if value < band[0]:
            verdict = "outside"
        else:
            verdict, reason = "not comparable", f"the model gives an upper bound only (≤ {num(value)}, the first " \
                "trusted row); pass --study for the members' rows below it"
    out.append(entry("elastic → plastic: dissipated energy exceeds stored from φ", name, "≈ 0.2", band, value,
                     interval, seeds, verdict=verdict, reason=reason, note=note,
                     model_text=("≤ " if upper else "") + est(regimes.get("elastic_to_plastic_phi"))))
    return out


def only_rolling(c):
    """How far up in φ only rolling ruptures happen (a qualitative statement of the paper)."""
    members, name, n, no_members, boot = c.members, c.name, c.n, c.no_members, c.boot
    out = []
    # At low phi only rolling ruptures.
    if members and all(r["sliding"] is not None and r["normal"] is not None for m in members for r in m["rows"]):
        def first_other(m):
            for k in range(1, len(m["rows"])):
                if m["rows"][k]["sliding"] + m["rows"][k]["normal"] > m["rows"][k - 1]["sliding"] + m["rows"][k - 1]["normal"]:
                    return k
            return len(m["rows"])

        def only_rolling_phi(draw):
            k = statistics.median_low([first_other(m) for m in draw])
            return mean_of(members, k - 1, "phi")
        firsts = [first_other(m) for m in members]
        rolling_first = all(m["rows"][1]["rolling"] and m["rows"][1]["rolling"] > 0 for m in members)
        holds = min(firsts) > 1 and rolling_first
        out.append(entry("only rolling ruptures at low φ: up to φ", name, "only rolling ruptures at low φ (no φ given)",
                         None, only_rolling_phi(members), boot(only_rolling_phi, "rolling", True), n,
                         verdict="inside" if holds else "outside",
                         note=f"qualitative statement, {'holds' if holds else 'does not hold'}: median over members "
                              f"of the last row before the first sliding reset or normal break (lowest member: "
                              f"φ = {num(mean_of(members, min(firsts) - 1, 'phi'))})"))
    else:
        out.append(entry("only rolling ruptures at low φ: up to φ", name, "only rolling ruptures at low φ (no φ given)",
                         None, reason=no_members or "the member curves have no rupture counts"))
    return out


def normal_break_onset(c):
    """The onset of normal breaks per member, by two rules (first break, sustained breaks)."""
    members, name, paper, n, no_members, boot = c.members, c.name, c.paper, c.n, c.no_members, c.boot
    out = []
    # Onset of normal breaks, per member.
    onset_band = paper["normal_onset"]
    published_onset = f"between {onset_band[0]:g} and {onset_band[1]:g}"
    if members and all(r["normal"] is not None for m in members for r in m["rows"]):
        K = len(members[0]["rows"])
        mids = {k: math.sqrt(mean_of(members, k - 1, "phi") * mean_of(members, k, "phi")) for k in range(1, K)}

        def onset(m, rule):
            breaks = [m["rows"][k]["normal"] - m["rows"][k - 1]["normal"] for k in range(1, K)]
            for k in range(1, K):
                if rule == "first" and breaks[k - 1] > 0:
                    return k
                if rule == "sustained" and all(b > 0 for b in breaks[k - 1:]):
                    return k
            return K  # never: after the last interval

        for rule, label in (("first", "first interval with a normal break"),
                            ("sustained", "first interval from which every later interval has a normal break")):
            def stat(draw, rule=rule):
                k = statistics.median_low([onset(m, rule) for m in draw])
                return mids.get(k)
            per = sorted(onset(m, rule) for m in members)
            counts = {}
            for k in per:
                counts[k] = counts.get(k, 0) + 1
            listing = ", ".join(f"({num(mean_of(members, k - 1, 'phi'))}, {num(mean_of(members, k, 'phi'))}] ×{c}"
                                if k < K else f"none ×{c}" for k, c in sorted(counts.items()))
            k_med = statistics.median_low(per)
            value = mids.get(k_med)
            out.append(entry(f"onset of normal breaks, per member ({rule})", name, published_onset, onset_band, value,
                             boot(stat, f"onset-{rule}", True), n,
                             phi_range=(f"interval ({num(mean_of(members, k_med - 1, 'phi'))}, "
                                        f"{num(mean_of(members, k_med, 'phi'))}]" if value is not None else None),
                             note=f"{label}; the value is that interval's φ_mid, the lower median over members "
                                  f"(interval: bootstrap of the median); by member: {listing}"))
            out[-1]["detail"] = rule == "sustained"
    else:
        for rule in ("first", "sustained"):
            out.append(entry(f"onset of normal breaks, per member ({rule})", name, published_onset, onset_band,
                             reason=no_members or "the member curves have no rupture counts"))
    return out


def pooled_boundary(c):
    """The product's single → multi-mode boundary on the pooled break rate; its entry carries
    "pooled", the note the observables table prints beside the boundary."""
    members, name, paper, n, regimes = c.members, c.name, c.paper, c.n, c.regimes
    out = []
    # The product's pooled single -> multi-mode boundary.
    value, interval, seeds = estimate_parts(regimes.get("single_to_multi_mode_phi"))
    note = "the product's regime rule on the pooled (ensemble-mean) break rate"
    pooled = None
    if value is not None and members and all(r["normal"] is not None for m in members for r in m["rows"]):
        k0 = next((k for k in range(1, len(members[0]["rows"]))
                   if abs(mean_of(members, k - 1, "phi") - value) < 1e-9 * max(1.0, value)), None)
        if k0 is not None:
            breakers = [(m["seed"], m["rows"][k0]["normal"] - m["rows"][k0 - 1]["normal"]) for m in members
                        if m["rows"][k0]["normal"] > m["rows"][k0 - 1]["normal"]]
            total = sum(b for _, b in breakers)
            pooled = (f"pooled over members: its first interval has {int(total)} normal "
                      f"break{'s' if total != 1 else ''} in {len(breakers)} of {n} members; per member, breaks begin "
                      "later: see Against the paper")
            note += (f"; its first interval ({num(value)}, {num(mean_of(members, k0, 'phi'))}] has "
                     f"{int(total)} normal break{'s' if total != 1 else ''} in {len(breakers)} of {n} members "
                     f"(seed{'s' if len(breakers) != 1 else ''} {', '.join(str(s) for s, _ in breakers)}): "
                     "any break in any member makes the pooled rate positive")
    out.append(entry("single → multi-mode boundary φ (product's rule)", name,
                     f"regime II up to {paper['regime_II'][1]:g}, III from ≈ {paper['regime_III']:g}",
                     (paper["regime_II"][1], paper["regime_III"]), value, interval, seeds, note=note))
    if pooled:
        out[-1]["pooled"] = pooled
    return out


def lambdas(c):
    """λ_II and λ_III over the paper's φ ranges, and the product's own regime fits beside them."""
    ensemble, members, name, paper, n, ks, no_members, boot = (
        c.ensemble, c.members, c.name, c.paper, c.n, c.ks, c.no_members, c.boot)
    out = []
    # lambda over the paper's ranges, and the product's regime fits.
    # The paper's φ are its rows (the same series as the model's: 0.16, 0.176, 0.194, 0.214, ..., 0.313,
    # 0.344, ...) given to two digits, so its ranges are read on the rows' φ to two digits: regime II
    # "0.2 < φ < 0.31" holds the row at 0.313 (normal breaks start only after it, between 0.31 and
    # 0.34), regime III "above ≈ 0.46" starts at the row 0.459.
    for regime, key, (lo, hi, lo_open, hi_open), stated in (
            ("II", "single_mode_plastic", (paper["regime_II"][0], paper["regime_II"][1], True, False),
             f"{paper['regime_II'][0]:g} < φ < {paper['regime_II'][1]:g}"),
            ("III", "multi_mode_plastic", (paper["regime_III"], None, False, False), f"φ ≥ {paper['regime_III']:g}")):
        centre, sigma = paper[f"lambda_{regime}"]
        published = f"{centre:g} ± {sigma:g}"
        band = (centre - sigma, centre + sigma)
        fit_ks = ks_in(members, ks, lo, hi, lo_open, hi_open, digits=2)

        def lam(draw, fit_ks=fit_ks):
            fit = loglog_slope([(mean_of(draw, k, "phi"), mean_of(draw, k, "P")) for k in fit_ks])
            return fit[0] if fit else None
        value = lam(members) if members else None
        out.append(entry(f"λ_{regime}, P_y = C φ^λ over the paper's range", name, published, band, value,
                         boot(lam, f"lambda-{regime}") if value is not None else None, n or None,
                         phi_range=stated + " (the paper's rows, φ to two digits)",
                         reason=no_members or (f"fewer than 3 trusted rows in {stated}" if value is None else None),
                         note=f"mean curve of the members' equilibrated, spanning rows: {rows_text(members, fit_ks)}"
                         if members else None))
        fit = fit_of(ensemble, key)
        value, interval, seeds = estimate_parts(as_dict(fit).get("exponent"))
        label = dict(REGIMES)[key]
        out.append(entry(f"λ_{regime}: the product's {label} fit", name, published, band, value, interval, seeds,
                         phi_range=(f"φ {num(fit['phi_min'])}–{num(fit['phi_max'])}"
                                    if isinstance(fit, dict) and finite(fit.get("phi_min")) and finite(fit.get("phi_max"))
                                    else None),
                         reason=(as_dict(fit).get("error") if value is None else None),
                         note="over the product's regime rows (its own rule, not the paper's φ range)"))
    return out


def gel_point(c):
    """The gel-point form P_y = C′ (φ − φ_g)^λ′: over the paper's range, and the product's fit."""
    ensemble, members, name, bond, no_members = c.ensemble, c.members, c.name, c.bond, c.no_members
    out = []
    # The gel-point form over phi_g < phi < 0.2.
    if bond == 1:
        if members:
            below = [k for k in range(1, len(members[0]["rows"]))
                     if (mean_of(members, k, "phi") or 1) < 0.2 and (mean_of(members, k, "P") or 0) > 0]
            spanning = [k for k in below if all(m["rows"][k]["spans"] for m in members)]
            why = f"not determined ({len(below)} rows below φ = 0.2, {len(spanning)} of them with every member " \
                  f"spanning; 3 parameters)"
        else:
            why = no_members
        for label, published, band in (("gel point φ_g", "≈ 0.15", (0.145, 0.155)), ("λ′", "≈ 1.5", (1.45, 1.55))):
            out.append(entry(f"{label}, P_y = C′ (φ − φ_g)^λ′ over φ_g < φ < 0.2", name, published, band,
                             reason=why, phi_range="φ_g < φ < 0.2",
                             model_text="not determined" if members else DASH))
    gel = as_dict(ensemble.get("gel_point"))
    for label, key, published, band in (("gel point φ_g", "phi_g", "≈ 0.15", (0.145, 0.155)),
                                         ("λ′", "exponent", "≈ 1.5", (1.45, 1.55))):
        value, interval, seeds = estimate_parts(gel.get(key))
        wider = f"φ {num(gel.get('phi_min'))}–{num(gel.get('phi_max'))}" if finite(gel.get("phi_min")) else None
        out.append(entry(f"{label}: the product's gel-point fit", name,
                         published + (" (bond 1)" if bond == 1 else " (fitted to bond 1 only)"),
                         band if bond == 1 else None, value, interval, seeds, comparable=False, phi_range=wider,
                         reason=(f"the product fits over {wider}, not φ_g < φ < 0.2" if wider else
                                 (gel.get("error") or "no gel-point fit")) if bond == 1 else
                         "the paper fits the gel-point form to bond 1 only"))
    return out


def xi_exponents(c):
    """The exponent of ξ^(0.5): the product's fit and its sensitivity to the range."""
    ensemble, members, name, n, ks, no_members, boot = c.ensemble, c.members, c.name, c.n, c.ks, c.no_members, c.boot
    out = []
    # xi^(0.5): the product's fit and its sensitivity to the range.
    value, interval, seeds = estimate_parts(as_dict(fit_in(ensemble, "xi_power_law")).get("exponent"))
    xi_fit = as_dict(fit_in(ensemble, "xi_power_law"))
    out.append(entry("exponent of ξ^(0.5) ∝ φ^x: the product's fit", name, "−1.96 ± 0.08", (-2.04, -1.88), value,
                     interval, seeds,
                     phi_range=f"φ {num(xi_fit.get('phi_min'))}–{num(xi_fit.get('phi_max'))}"
                     if finite(xi_fit.get("phi_min")) else None,
                     reason=xi_fit.get("error") if value is None else None,
                     note="the paper states one exponent (the fractal estimate −1/(d − D_f) ≈ −2.2); compared with "
                          "each bond"))
    xi_ks = [k for k in range(len(members[0]["rows"]))
             if all(k in m["xi"] for m in members)] if members else []
    for label, chosen in (("all rows with ξ", xi_ks), ("φ ≤ 0.5", ks_in(members, xi_ks, hi=0.5)),
                          ("k ≥ 1 (φ ≥ 0.16, the initial network left out)", [k for k in xi_ks if k >= 1]),
                          ("trusted rows only (every member spans)", [k for k in xi_ks if k in ks])):
        def slope(draw, chosen=chosen):
            fit = loglog_slope([(mean_of(draw, k, "phi"), sum(m["xi"][k] for m in draw) / len(draw)) for k in chosen])
            return fit[0] if fit else None
        value = slope(members) if members else None
        out.append(entry(f"exponent of ξ^(0.5) ∝ φ^x over {label}", name, "−1.96 ± 0.08", (-2.04, -1.88), value,
                         boot(slope, f"xi-{label}") if value is not None else None, n or None,
                         phi_range=rows_text(members, chosen) if members else None,
                         reason=no_members or ("fewer than 3 rows with ξ" if value is None else None),
                         note="members' structure.json ξ^(0.5), mean per row; the range of the paper's figure could "
                              "not be inferred from its text"))
        out[-1]["detail"] = True
    return out


def profile(c):
    """The φ profile across the cell: a drop in the middle at φ ≈ 0.16, uniform after."""
    members, name, n, no_members, boot = c.members, c.name, c.n, c.no_members, c.boot
    out = []
    # phi profile: a drop in the middle at 0.16, uniform after.
    if members and all(len(r["profile"]) >= 5 for m in members for r in m["rows"]):
        def middle(m, k):
            p = m["rows"][k]["profile"]
            mean = sum(p) / len(p)
            mid = p[2 * len(p) // 5: 3 * len(p) // 5]
            return (sum(mid) / len(mid)) / mean if mean > 0 else None
        K = len(members[0]["rows"])
        k16 = row_near([{"k": k, "phi": mean_of(members, k, "phi")} for k in range(K)], 0.16)
        if k16 is not None:
            k1 = k16["k"]

            def ratio(draw, k=None):
                values = [middle(m, k1 if k is None else k) for m in draw]
                return sum(values) / len(values) if all(v is not None for v in values) else None
            uniform = next((k for k in range(k1 + 1, K) if all(abs(ratio(members, j) - 1) <= 0.05
                                                                for j in range(k, K))), None)
            value = ratio(members)
            interval = boot(ratio, "profile")
            holds = interval[1] is not None and interval[1] < 1 and uniform is not None
            out.append(entry("φ̄(y): middle fifth / mean at φ ≈ 0.16", name, "a drop in the middle at φ = 0.16, "
                             "uniform after", None, value, interval, n, verdict="inside" if holds else "outside",
                             phi_range=f"k = {k1}, φ = {num(mean_of(members, k1, 'phi'))}",
                             note=f"qualitative statement, {'holds' if holds else 'does not hold'}: ratio < 1 is a "
                                  "drop; uniform (the middle fifth within 5 % of the mean in every later row) from "
                                  + (f"φ = {num(mean_of(members, uniform, 'phi'))} on" if uniform is not None else
                                     "no row")))
    else:
        out.append(entry("φ̄(y): middle fifth / mean at φ ≈ 0.16", name, "a drop in the middle at φ = 0.16, uniform "
                         "after", None, reason=no_members or "the member curves have no φ profiles"))
    return out


OBSERVABLES = (fractal_dimension, contact_numbers, span_of_p, dissipation_crossing, only_rolling, normal_break_onset,
               pooled_boundary, lambdas, gel_point, xi_exponents, profile)


def compare_ensemble(ensemble, members):
    """The comparison entries of one ensemble, in the order of OBSERVABLES."""
    c = Ensemble(ensemble, members)
    out = [e for observable in OBSERVABLES for e in observable(c)]
    for e in out:
        if e["seeds"] is None and e["model"] is not None and members and e["verdict"] != "not comparable":
            e["seeds"] = c.n
    return out


def comparison(analysis, study):
    """All comparison entries and notes on what could not be computed."""
    entries, notes = [], []
    for ensemble in analysis["ensembles"]:
        bond = bond_of(ensemble["name"])
        if bond is None:
            notes.append(f"`{ensemble['name']}` is not compared: its name names neither bond 1 nor bond 2.")
            continue
        members, member_notes = load_members(study, ensemble) if study else ([], [])
        if study and not members:
            notes.append(f"`{ensemble['name']}`: no member curves under `{study}` "
                         f"({'; '.join(member_notes) or 'none found'}); the analyses of the members are left out.")
        elif member_notes:
            notes.append(f"`{ensemble['name']}`: members left out: {'; '.join(member_notes)}.")
        entries += compare_ensemble(ensemble, members)
    if any(bond_of(e["name"]) == 1 for e in analysis["ensembles"]):
        entries.append(bending_entry())
    return entries, notes
