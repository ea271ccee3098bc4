#!/usr/bin/env bash
# tools/reproduction_report.py on a synthetic study analysis (gel.study-analysis.v1): two
# ensembles, one complete (4 seeds, intervals, regimes, fits, gel point, xi^(0.5), D_f) and one
# thin (2 seeds: no bootstrap intervals; a failed gel-point fit, null intervals, null fits). The
# report must hold the one table with both ensembles, the numbers as "value [lo, hi]" with 3
# significant digits, "—" with the reason for what is missing; every PNG it links must exist
# and be a real PNG; the snapshots come from a fake study directory drawn by the real gelsim; and
# a JSON of another format is refused with exit code 2 naming the format. The comparison with the
# published values (comparison.json) has the required keys for both ensembles, and its verdicts are
# right on members built to fall inside or outside a published band.
set -euo pipefail
GELSIM=${1:?usage: test_reproduction_report.sh GELSIM}
PYTHON=/usr/bin/python3  # Debian's interpreter: the tool uses the standard library and gnuplot only
TOOL="$(cd "$(dirname "$0")/../.." && pwd)/tools/reproduction_report.py"
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
command -v gnuplot > /dev/null || fail "gnuplot is not installed (scripts/setup.sh installs gnuplot-nox)"

# 1. The synthetic analysis, and a study directory whose bond1 seed 1 has a configuration for
#    every row (one generated gel, copied) and whose bond2 seed 5 has no snapshots at all.
"$GELSIM" generate --preset quick --seed 1 --out "$WORK/gel.json" > /dev/null
"$PYTHON" - "$WORK" <<'PY'
import json, math, os, shutil, sys
work = sys.argv[1]

def e(value, rel=0.05, n=4):
    if n < 3:
        return {"value": value, "lo": None, "hi": None, "n": n}
    return {"value": value, "lo": value * (1 - rel), "hi": value * (1 + rel), "n": n}

def ensemble(name, seeds, phi0, rows, regime_at, n):
    phis = [phi0 * 1.22 ** k for k in range(rows)]
    out = {"name": name, "seeds": seeds, "members": len(seeds), "particles": 256, "rows": [], "intervals": [],
           "excluded_rows": [], "extra_field_from_the_future": {"ignored": True}}
    cumulative = [0.0, 0.0, 0.0]
    for k, phi in enumerate(phis):
        trusted = k >= 2
        regime = None if not trusted else ("elastic" if phi < regime_at[0] else
                                           "multi-mode-plastic" if phi >= regime_at[1] else "single-mode-plastic")
        p = 0.0 if k == 0 else 0.8 * phi ** 4.26
        z = 2.0 + 2.0 * (phi - phi0)
        out["rows"].append({"k": k, "phi": e(phi, 0.001, n), "P": e(p, 0.08, n) if p else e(0.0, 0, n),
                            "P_top": e(p, 0.1, n), "P_bot": e(p, 0.1, n), "contact_number": e(z, 0.02, n),
                            "stored_energy": e(0.1 * k, 0.1, n), "dissipated_energy": e(0.05 * k * k, 0.1, n),
                            "ruptures_normal": e(cumulative[0], 0.2, n), "ruptures_sliding": e(cumulative[1], 0.2, n),
                            "ruptures_rolling": e(cumulative[2], 0.2, n), "equilibrated_members": n,
                            "spanning_members": n if k >= 2 else 0, "trusted": trusted, "regime": regime})
        if k >= 1:
            mid = math.sqrt(phis[k - 1] * phi)
            gn = 0.0 if mid < regime_at[1] else 0.02 * k
            out["intervals"].append({"k": k, "phi_lo": phis[k - 1], "phi_hi": phi, "phi_mid": mid,
                                     "stored_rate": e(0.5 + 0.1 * k, 0.1, n), "dissipated_rate": e(0.05 * k * k, 0.2, n),
                                     "gamma_normal": e(gn, 0.3, n), "gamma_sliding": e(0.1 * k, 0.2, n),
                                     "gamma_rolling": e(0.3 * k, 0.1, n), "regime": regime if k >= 3 else None,
                                     "trusted": k >= 3})
    out["excluded_rows"] = [{"k": 1, "phi": phis[1], "reason": "not spanning: 0 of %d members span the walls" % n}]
    return out, phis

bond1, phis = ensemble("bond1", [1, 2, 3, 4], 0.12, 10, (0.21, 0.35), 4)
bond1["regimes"] = {"elastic_to_plastic_phi": {"value": 0.21, "lo": 0.2, "hi": 0.225, "n": 4},
                    "single_to_multi_mode_phi": {"value": 0.35, "lo": 0.33, "hi": 0.37, "n": 4},
                    "rule": "elastic -> plastic where the dissipated energy reaches the stored energy"}
fit = lambda x, lo, hi, a, b, pts: {"exponent": {"value": x, "lo": lo, "hi": hi, "n": 4},
                                    "prefactor": {"value": 0.8, "lo": 0.7, "hi": 0.9, "n": 4},
                                    "phi_min": a, "phi_max": b, "points": pts, "rms_log_residual": 0.031}
bond1["power_law"] = {"all": fit(4.26, 4.1, 4.4, phis[2], phis[9], 8),
                      "elastic": fit(4.0, 3.5, 4.6, phis[2], phis[3], 2),
                      "single_mode_plastic": fit(4.3, 4.1, 4.5, phis[3], phis[5], 3),
                      "multi_mode_plastic": fit(4.28, 4.2, 4.35, phis[6], phis[9], 4)}
bond1["gel_point"] = {"phi_g": {"value": 0.0913, "lo": 0.08, "hi": 0.1, "n": 4},
                      "exponent": {"value": 3.13, "lo": 2.9, "hi": 3.3, "n": 4},
                      "prefactor": {"value": 0.5, "lo": 0.4, "hi": 0.6, "n": 4},
                      "phi_min": phis[2], "phi_max": phis[5], "points": 4, "at_bound": False, "converged": True,
                      "resamples_at_bound": 3, "rows": [2, 3, 4, 5]}
bond1["xi_05"] = [{"k": k, "phi": phis[k], "xi": e(12.0 * (phis[k] / 0.12) ** -1.6, 0.05)} for k in range(10)]
bond1["xi_power_law"] = {"exponent": {"value": -1.6, "lo": -1.7, "hi": -1.5, "n": 4},
                         "prefactor": {"value": 12.0 * 0.12 ** 1.6, "lo": 0.4, "hi": 0.5, "n": 4},
                         "phi_min": phis[0], "phi_max": phis[9], "points": 10, "rms_log_residual": 0.01}
bond1["fractal_dimension_initial"] = {"value": 1.43, "lo": 1.4, "hi": 1.46, "n": 4}
bond1["power_law"]["elastic"]["exponent"] = {"value": 4.0, "lo": None, "hi": None, "n": 4, "resamples_with_value": 90}
bond1["structure_seconds"] = 3.5

bond2, _ = ensemble("bond2", [5, 6], 0.12, 8, (0.2, 9.0), 2)
bond2["intervals"] = None
bond2["regimes"] = {"elastic_to_plastic_phi": {"value": 0.2, "lo": None, "hi": None, "n": 2}, "single_to_multi_mode_phi": None,
                    "elastic_to_plastic_at_first_trusted_row": True,
                    "rule": "elastic -> plastic where the dissipated energy reaches the stored energy"}
bond2["power_law"] = {"all": {"exponent": {"value": 3.9, "lo": None, "hi": None, "n": 2, "resamples": 0,
                                           "resamples_with_value": 0},
                              "prefactor": {"value": 0.8, "lo": None, "hi": None, "n": 2},
                              "phi_min": 0.18, "phi_max": 0.43, "points": 5, "rms_log_residual": 0.02},
                      "elastic": None, "single_mode_plastic": None,
                      "single_mode_plastic_error": "fewer than 3 trusted rows in the regime",
                      "multi_mode_plastic": {"error": "no trusted row in the regime"}}
bond2["gel_point"] = {"error": "fewer than 3 trusted rows below the single -> multi-mode boundary"}
bond2["xi_05"] = []
bond2["xi_power_law"] = None
bond2["xi_power_law_error"] = "no snapshots were analysed"
bond2["fractal_dimension_initial"] = None

analysis = {"format": "gel.study-analysis.v1", "bootstrap_samples": 200, "bootstrap_seed": 1, "confidence": 0.95,
            "ensembles": [bond1, bond2]}
json.dump(analysis, open(os.path.join(work, "analysis.json"), "w"), indent=1)
json.dump(dict(analysis, format="gel.run-analysis.v1"), open(os.path.join(work, "other.json"), "w"))

seed_dir = os.path.join(work, "study", "bond1", "seed_1")
os.makedirs(os.path.join(seed_dir, "snapshots"))
rows = []
for k, phi in enumerate(phis):
    name = f"snapshots/row_{k:03d}.json"
    shutil.copy(os.path.join(work, "gel.json"), os.path.join(seed_dir, name))
    rows.append({"k": k, "phi": phi, "snapshot": name})
json.dump({"rows": rows}, open(os.path.join(seed_dir, "curve.json"), "w"))
os.makedirs(os.path.join(work, "study", "bond2", "seed_5"))
json.dump({"rows": [{"k": 0, "phi": 0.12, "snapshot": ""}]},
          open(os.path.join(work, "study", "bond2", "seed_5", "curve.json"), "w"))
PY

# 2. The report, with snapshots.
"$PYTHON" "$TOOL" "$WORK/analysis.json" --out "$WORK/report/reproduction.md" --runs "$WORK/study" --gelsim "$GELSIM" \
  --command "gelsim study --preset test --out study" --cost "0.1 core-hours" > "$WORK/out.log" 2>&1 \
  || fail "the tool failed: $(tail -5 "$WORK/out.log")"
MD="$WORK/report/reproduction.md"
[ -s "$MD" ] || fail "no report written"
grep -q "^| observable | unit | bond1 | seeds | bond2 | seeds |" "$MD" || fail "no observables table with both ensembles"
grep -q "4.26 \[4.1, 4.4\]" "$MD" || fail "the exponent of all rows is not printed as 4.26 [4.1, 4.4]"
grep -q "0.21 \[0.2, 0.225\]" "$MD" || fail "the elastic -> plastic boundary is not printed with its interval"
grep -q "≤ 0.2 (no interval: 2 seeds) (the first trusted row" "$MD" || fail "a boundary at the first trusted row is not marked as an upper bound"
grep -q "0.0913 \[0.08, 0.1\]" "$MD" || fail "phi_g is not printed with its interval"
grep -q "— (fewer than 3 trusted rows below the single -> multi-mode boundary)" "$MD" \
  || fail "the missing gel point of bond2 is not a dash with its reason"
grep -q "— (fewer than 3 trusted rows in the regime)" "$MD" || fail "a failed fit (KEY_error beside it) is not a dash with its reason"
grep -q "— (no trusted row in the regime)" "$MD" || fail "a failed fit ({\"error\": ...}) is not a dash with its reason"
grep -q "— (no snapshots were analysed)" "$MD" || fail "the missing xi^(0.5) fit is not a dash with its reason"
grep -q "4 (no interval: 90 of 200 resamples gave a value)" "$MD" || fail "an exponent found in too few resamples does not say so"
grep -q "3.9 (no interval: 2 seeds)" "$MD" || fail "a value without interval does not say why"
grep -q "not spanning: 0 of 4 members span the walls" "$MD" || fail "the excluded rows are not listed"
grep -q "gelsim study --preset test --out study" "$MD" || fail "the command is not in the report"
grep -q "0.1 core-hours" "$MD" || fail "the cost is not in the report"
grep -q "no row near φ = 0.7" "$MD" || fail "bond2, which stops before 0.7, does not say so"
long=$(grep -Eo '[0-9]+\.[0-9]+' "$MD" | sed 's/\.//; s/^0*//' | grep -E '[0-9]{4,}' || true)
[ -z "$long" ] || fail "numbers with more than 3 significant digits: $(echo $long | head -c 200)"
grep -q "bond2.*no snapshot" "$MD" || fail "the snapshot that is missing is not noted"

# 3. Every linked PNG exists, is a PNG and is not empty; the five figures and the snapshots of
#    bond1 (k = 0 and the first row of each of its three regimes) are among them.
links=$(grep -o '](\([^)]*\.png\))' "$MD" | sed 's/^](//; s/)$//')
[ "$(echo "$links" | grep -c .)" -ge 9 ] || fail "expected at least 9 linked PNGs, got: $links"
for png in compression.png rupture_rates.png contact_number.png energy_increments.png xi_05.png snapshot_bond1_seed1_k0.png; do
  echo "$links" | grep -q "$png" || fail "$png is not linked"
done
for link in $links; do
  file="$WORK/report/$link"
  [ -f "$file" ] || fail "linked figure $link does not exist"
  [ "$(head -c 8 "$file" | od -An -tx1 | tr -d ' \n')" = "89504e470d0a1a0a" ] || fail "$link is not a PNG"
  [ "$(stat -c %s "$file")" -gt 1024 ] || fail "$link is smaller than 1 kB"
done

# 3b. The figures' gnuplot scripts: every regime label above the frame (graph 1, lifted by a
#     positive offset), where it cannot cover a data point, no two labels of one figure on the
#     same row where they could overlap, and every title says what the error bars are and over
#     how many seeds.
"$PYTHON" - "$TOOL" "$WORK/analysis.json" <<'PY' || fail "the figures' scripts"
import json, os, re, sys
sys.path.insert(0, os.path.dirname(sys.argv[1]))
from reproduction import figures
ensembles = json.load(open(sys.argv[2]))["ensembles"]

class Capture:
    cairo = True
    def data(self, points):
        return "data"
    def draw(self, name, body, width=760, height=580):
        self.bodies[name] = body
        return name

plot = Capture()
plot.bodies = {}
for draw in (figures.figure_compression, figures.figure_ruptures, figures.figure_contacts, figures.figure_energy,
             figures.figure_xi):
    draw(plot, ensembles)
assert len(plot.bodies) == 5, sorted(plot.bodies)
labelled = 0
for name, body in plot.bodies.items():
    assert "95 % bootstrap intervals, bond1 n = 4, bond2 n = 2 seeds" in body, (name, re.findall(r"title .*", body))
    for panel in body.split("reset\n"):
        rows = []
        for line in panel.splitlines():
            if not line.startswith("set label"):
                continue
            m = re.search(r" at ([-0-9.e+]+), graph ([0-9.]+) .*offset [-0-9.]+,([0-9.]+)", line)
            assert m and float(m.group(2)) >= 1 and float(m.group(3)) > 0, (name, "label inside the frame", line)
            rows.append((float(m.group(1)), float(m.group(3))))
            labelled += 1
        # Labels at nearly one phi (two ensembles' boundaries) never share a row.
        for i, (x, row) in enumerate(rows):
            for x2, row2 in rows[i + 1:]:
                assert abs(x - x2) > 0.05 * x or row != row2, (name, rows)
assert labelled >= 8, labelled
PY

# 4. Without a gelsim the snapshots are left out with a note, the rest is written.
"$PYTHON" "$TOOL" "$WORK/analysis.json" --out "$WORK/nogelsim.md" --figures "$WORK/nogelsim" --runs "$WORK/study" \
  --gelsim "$WORK/no-such-gelsim" > "$WORK/out.log" 2>&1 || fail "the tool failed without gelsim: $(tail -5 "$WORK/out.log")"
grep -q "Snapshots were not drawn: no gelsim program" "$WORK/nogelsim.md" || fail "no note that snapshots were skipped"
[ -f "$WORK/nogelsim/compression.png" ] || fail "--figures was not honoured"

# 5. The comparison with the published values. The report of step 2 wrote it beside its figures,
#    from the analysis alone (its --runs directory has no complete member curves).
CMP="$WORK/report/reproduction/comparison.json"
[ -s "$CMP" ] || fail "no comparison.json beside the figures"
grep -q "^## Against the paper" "$MD" || fail "no section Against the paper"
grep -q "^| observable | bond | published | model \[95 % interval\] | seeds | φ range | verdict | note |" "$MD" \
  || fail "no table of published values"
#    A study directory whose members are built so that the verdicts are known: the paper's rows
#    (phi_k = 0.16 * 1.1^(k-1)); bond1 (4 members): P = s phi^5.8 (lambda_II = 5.8, inside 5.8 +- 0.5;
#    lambda_III = 5.8, outside 4.3 +- 0.2), first normal break in (0.313, 0.344] in every member (inside
#    "between 0.31 and 0.34"); bond2 (2 members): P = s phi^7 (lambda_II = 7, outside 5.8 +- 0.4), first
#    break in (0.285, 0.313] (outside "between 0.42 and 0.46").
"$PYTHON" - "$WORK/members" <<'PY'
import json, os, sys
root = sys.argv[1]
phis = [0.12] + [0.16 * 1.1 ** (k - 1) for k in range(1, 18)]
for name, seeds, exponent, first_break in (("bond1", [1, 2, 3, 4], 5.8, 9), ("bond2", [5, 6], 7.0, 8)):
    for seed in seeds:
        rows = []
        for k, phi in enumerate(phis):
            breaks = max(0, k - first_break + 1)
            rows.append({"k": k, "phi": phi, "P": (1 + 0.1 * seed) * phi ** exponent, "equilibrated": True,
                         "spans": k >= 1, "contact_number": 2 + phi, "stored_energy": 1.0 * k,
                         "dissipated_energy": 2.0 * k, "ruptures": {"normal": breaks, "sliding": 2 * breaks,
                                                                      "rolling": 10 * k},
                         "phi_profile": [phi * (0.8 if k == 1 and 8 <= i < 12 else 1.0) for i in range(20)]})
        folder = os.path.join(root, name, f"seed_{seed}")
        os.makedirs(folder)
        json.dump({"particles": 256, "rows": rows}, open(os.path.join(folder, "curve.json"), "w"))
        json.dump({"format": "gel.member-structure.v1", "options": {"fit_rmin": 2.0, "fit_rmax": 10.0},
                   "rows": [{"k": k, "xi_05": 30 * (phi / 0.12) ** -1.96} for k, phi in enumerate(phis)]},
                  open(os.path.join(folder, "structure.json"), "w"))
PY
"$PYTHON" "$TOOL" "$WORK/analysis.json" --out "$WORK/members.md" --study "$WORK/members" \
  --comparison "$WORK/members.json" > "$WORK/out.log" 2>&1 || fail "the tool failed with --study: $(tail -5 "$WORK/out.log")"
"$PYTHON" - "$CMP" "$WORK/members.json" <<'PY' || fail "the comparison JSON is wrong"
import json, sys
required = {"observable", "ensemble", "published", "model", "interval", "seeds", "verdict"}
for path in sys.argv[1:]:
    entries = json.load(open(path))
    assert isinstance(entries, list) and entries, f"{path}: not a non-empty list"
    for e in entries:
        assert required <= set(e), f"{path}: {e.get('observable')} lacks {required - set(e)}"
        assert e["verdict"] in ("inside", "outside", "not comparable"), e
        assert e["verdict"] != "not comparable" or e["reason"], f"not comparable without a reason: {e}"
    assert {"bond1", "bond2"} <= {e["ensemble"] for e in entries}, f"{path}: not both ensembles"

def one(entries, ensemble, observable):
    found = [e for e in entries if e["ensemble"] == ensemble and e["observable"] == observable]
    assert len(found) == 1, (ensemble, observable, len(found))
    return found[0]

# From the analysis alone: contact numbers of the synthetic analysis (2 at k = 0: inside [1.5, 2.5];
# 2 + 2 (0.12 * 1.22^9 - 0.12) = 3.2 at the last row: outside [3.5, 4.5]); the member analyses say why not.
entries = json.load(open(sys.argv[1]))
e = one(entries, "bond1", "contact number, initial network")
assert e["verdict"] == "inside" and abs(e["model"] - 2.0) < 1e-9 and e["seeds"] == 4, e
e = one(entries, "bond1", "contact number at the last row")
assert e["verdict"] == "outside" and abs(e["model"] - (2 + 2 * (0.12 * 1.22 ** 9 - 0.12))) < 1e-6, e
e = one(entries, "bond1", "λ_III: the product's multi-mode plastic fit")
assert e["verdict"] == "inside" and e["model"] == 4.28 and e["interval"] == [4.2, 4.35], e
e = one(entries, "bond2", "λ_III: the product's multi-mode plastic fit")
assert e["verdict"] == "not comparable" and e["reason"] == "no trusted row in the regime", e
e = one(entries, "bond1", "λ_II, P_y = C φ^λ over the paper's range")
assert e["verdict"] == "not comparable" and e["model"] is None, e

# From the constructed members.
entries = json.load(open(sys.argv[2]))
e = one(entries, "bond1", "λ_II, P_y = C φ^λ over the paper's range")
assert e["verdict"] == "inside" and abs(e["model"] - 5.8) < 1e-9 and e["seeds"] == 4, e
assert abs(e["interval"][0] - 5.8) < 1e-9 and abs(e["interval"][1] - 5.8) < 1e-9, e
assert "k = 4–8" in e["note"], e  # 0.214 ... 0.313: the paper's rows to two digits
e = one(entries, "bond1", "λ_III, P_y = C φ^λ over the paper's range")
assert e["verdict"] == "outside" and abs(e["model"] - 5.8) < 1e-9, e
e = one(entries, "bond2", "λ_II, P_y = C φ^λ over the paper's range")
assert e["verdict"] == "outside" and abs(e["model"] - 7.0) < 1e-9 and e["interval"] is None and e["seeds"] == 2, e
e = one(entries, "bond1", "onset of normal breaks, per member (first)")
assert e["verdict"] == "inside" and abs(e["model"] - (0.16 ** 2 * 1.1 ** 15) ** 0.5) < 1e-9, e
e = one(entries, "bond2", "onset of normal breaks, per member (first)")
assert e["verdict"] == "outside" and abs(e["model"] - (0.16 ** 2 * 1.1 ** 13) ** 0.5) < 1e-9, e
e = one(entries, "bond1", "exponent of ξ^(0.5) ∝ φ^x over all rows with ξ")
assert e["verdict"] == "inside" and abs(e["model"] + 1.96) < 1e-9, e
e = one(entries, "bond1", "φ̄(y): middle fifth / mean at φ ≈ 0.16")
assert e["verdict"] == "inside" and e["model"] < 1, e
e = one(entries, "bond1", "gel point φ_g, P_y = C′ (φ − φ_g)^λ′ over φ_g < φ < 0.2")
assert e["verdict"] == "not comparable" and e["reason"].startswith("not determined (3 rows below φ = 0.2"), e
PY
grep -Fq "| λ_II, P_y = C φ^λ over the paper's range | bond2 | 5.8 ± 0.4 | 7 |" "$WORK/members.md" \
  || fail "the members' report does not show bond2's lambda_II against 5.8 ± 0.4"

# 6. Another format is refused with exit code 2, naming the format; so is a file that is not JSON.
set +e
"$PYTHON" "$TOOL" "$WORK/other.json" --out "$WORK/other.md" > "$WORK/err" 2>&1
code=$?
set -e
[ "$code" -eq 2 ] || fail "another format gave exit code $code, not 2"
grep -q "gel.run-analysis.v1" "$WORK/err" && grep -q "gel.study-analysis.v1" "$WORK/err" \
  || fail "the refusal does not name the formats: $(cat "$WORK/err")"
[ ! -e "$WORK/other.md" ] || fail "a report was written for another format"
echo "not json" > "$WORK/bad.json"
set +e
"$PYTHON" "$TOOL" "$WORK/bad.json" --out "$WORK/bad.md" > "$WORK/err" 2>&1
code=$?
set -e
[ "$code" -eq 2 ] || fail "a file that is not JSON gave exit code $code, not 2"
echo "reproduction_report: all checks passed"
