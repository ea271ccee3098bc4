#!/usr/bin/env bash
# gelsim compress --thermo-every: OUT/thermo.csv read by pandas (Debian's /usr/bin/python3) under
# the documented columns, its last line the final state of curve.csv's last row, a resume of the
# finished run adding nothing, and the flag refused without --out.
set -euo pipefail
GELSIM="$1"
PYTHON=/usr/bin/python3  # Debian's interpreter: pandas is its package
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

"$GELSIM" compress --preset quick --seed 2 --steps 3 --phi-max 0.3 --out "$WORK/run" --thermo-every 2000 \
  > /dev/null 2> "$WORK/run.log" || fail "compression: $(tail -3 "$WORK/run.log")"
cp "$WORK/run/thermo.csv" "$WORK/thermo.before"
"$GELSIM" compress --resume "$WORK/run" > /dev/null 2> "$WORK/resume.log" || fail "resume: $(tail -3 "$WORK/resume.log")"
cmp -s "$WORK/run/thermo.csv" "$WORK/thermo.before" || fail "resuming a finished run changed its thermo log"

"$PYTHON" - "$WORK/run" <<'PY' || fail "pandas disagrees with the documented thermo log"
import sys
import pandas

run = sys.argv[1]
thermo = pandas.read_csv(f"{run}/thermo.csv", float_precision="round_trip")
columns = ["step [count]", "time [t0]", "k", "phase", "phi [1]", "P_top [F0/a^2]", "P_bot [F0/a^2]", "P [F0/a^2]",
           "kinetic_energy [F0 a]", "stored_energy [F0 a]", "ruptures_normal [count]", "ruptures_sliding [count]",
           "ruptures_rolling [count]", "bonds_created [count]"]
assert list(thermo.columns) == columns, list(thermo.columns)
for column in columns:
    if column != "phase":
        assert pandas.api.types.is_numeric_dtype(thermo[column]), (column, thermo[column].dtype)
assert pandas.api.types.is_integer_dtype(thermo["step [count]"])
assert set(thermo["phase"]) <= {"compressing", "waiting", "relaxing", "done"}, set(thermo["phase"])
steps = thermo["step [count]"]
assert steps.iloc[0] == 0 and steps.is_monotonic_increasing and steps.is_unique, steps
# A line at step 0 and one at or after each multiple of 2000; the final state's line is one of
# them when the last chunk crossed a multiple (then the line written there already says "done").
assert len(thermo) >= 1 + steps.iloc[-1] // 2000, (len(thermo), steps.iloc[-1])

curve = pandas.read_csv(f"{run}/curve.csv", float_precision="round_trip")
last, final = curve.iloc[-1], thermo.iloc[-1]
assert final["phase"] == "done" and final["k"] == last["k"], (final["phase"], final["k"])
for line_column, row_column in [("step [count]", "steps [count]"), ("time [t0]", "sim_time [t0]"),
                                ("phi [1]", "phi [1]"), ("P_top [F0/a^2]", "P_top [F0/a^2]"),
                                ("P_bot [F0/a^2]", "P_bot [F0/a^2]"), ("P [F0/a^2]", "P [F0/a^2]"),
                                ("kinetic_energy [F0 a]", "kinetic_energy [F0 a]"),
                                ("stored_energy [F0 a]", "stored_energy [F0 a]"),
                                ("ruptures_normal [count]", "ruptures_normal [count]"),
                                ("ruptures_sliding [count]", "ruptures_sliding [count]"),
                                ("ruptures_rolling [count]", "ruptures_rolling [count]"),
                                ("bonds_created [count]", "bonds_created [count]")]:
    assert final[line_column] == last[row_column], (line_column, final[line_column], last[row_column])
print(f"ok: {len(thermo)} lines, the last one the final row")
PY

if "$GELSIM" compress --preset quick --thermo-every 100 > /dev/null 2> "$WORK/err"; then fail "--thermo-every without --out was accepted"; fi
grep -q -- "--thermo-every.*needs --out" "$WORK/err" || fail "the refusal does not say what is missing: $(cat "$WORK/err")"
echo "ok: thermo log"
