#!/usr/bin/env bash
# gelsim compress --seeds/--jobs, end to end with the real gelsim: members run in parallel, each
# gives the same rows as a single run of its seed, the ensemble's folder is what analyze-run, plot
# and export take, a SIGTERM stops every member with exit 4 and --resume finishes them bit for
# bit, and bad --seeds are refused with exit 2 before anything runs.
set -euo pipefail
GELSIM=${1:?usage: test_gelsim_ensemble.sh GELSIM}
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
SMALL=(--preset quick --fidelity fast --steps 2 --phi-max 0.2 --no-snapshots)

# The rows of two curve.json files, equal in every field but wall time.
same_rows() {
  python3 - "$1" "$2" <<'PY'
import json, sys
a, b = (json.load(open(p))["rows"] for p in sys.argv[1:3])
strip = lambda rows: [{k: v for k, v in r.items() if k != "wall_seconds"} for r in rows]
if strip(a) != strip(b):
    sys.exit(f"rows differ: {sys.argv[1]} ({len(a)} rows) vs {sys.argv[2]} ({len(b)} rows)")
PY
}

# 1. Two members at a time; each equals its single run.
"$GELSIM" compress "${SMALL[@]}" --seeds 3-4 --jobs 2 --out "$WORK/ens" --json > "$WORK/ens.json" 2> "$WORK/ens.log" \
  || fail "ensemble exited $?: $(tail -3 "$WORK/ens.log")"
grep -q "2 members, 2 at a time" "$WORK/ens.log" || fail "the ensemble did not run 2 members at a time"
for seed in 3 4; do
  "$GELSIM" compress "${SMALL[@]}" --seed "$seed" --out "$WORK/single_$seed" > /dev/null 2>&1 || fail "single run $seed"
  same_rows "$WORK/ens/seed_$seed/curve.json" "$WORK/single_$seed/curve.json" || fail "member $seed differs from its single run"
done
python3 - "$WORK/ens.json" <<'PY' || fail "ensemble summary"
import json, sys
d = json.load(open(sys.argv[1]))
assert d["seeds"] == [3, 4], d["seeds"]
last = d["summary"][-1]
ps = [m["curve"]["rows"][-1]["P"] for m in d["members"]]
assert last["members"] == 2 and abs(last["P_mean"] - sum(ps) / 2) <= 1e-15 * abs(last["P_mean"]), (last, ps)
# The summary names its rule: geld's GetCurve and the analyses say the same words.
assert d["ensemble_rule"].startswith("mean and sample standard deviation (n - 1; 0 for n = 1) over the members that reached row k"), d
PY

# The ensemble's folder stands for its finished members in analyze-run, plot and export; a
# member without a curve (failed, stopped) is named and left out.
mkdir "$WORK/ens/seed_9"
"$GELSIM" analyze-run "$WORK/ens" --no-structure --json > "$WORK/folder.json" 2> "$WORK/folder.log" \
  || fail "analyze-run of the ensemble's folder exited $?: $(tail -2 "$WORK/folder.log")"
grep -q "seed_9 has no curve.json (failed, stopped or still running): left out" "$WORK/folder.log" \
  || fail "the unfinished member is not named: $(cat "$WORK/folder.log")"
"$GELSIM" analyze-run "$WORK/ens/seed_3" "$WORK/ens/seed_4" --no-structure --json > "$WORK/named.json" 2>/dev/null \
  || fail "analyze-run of the members"
cmp -s "$WORK/folder.json" "$WORK/named.json" || fail "the folder's analysis differs from its members'"
# The ensemble's pictures say what their error bars are, in the axis title (the figure title
# is only in the kept script).
"$GELSIM" plot "$WORK/ens" > /dev/null 2>&1 || fail "plot of the ensemble's folder"
for figure in pressure contact_number energy_increments rupture_rates profiles; do
  grep -q '^set ylabel .*(mean ± s.d. over n = 2 runs)' "$WORK/ens/plots/gnuplot/$figure.gp" \
    || fail "$figure: the error bars are not named: $(grep '^set ylabel' "$WORK/ens/plots/gnuplot/$figure.gp")"
done
# Export: one file per member, named after it, each the member's own frames (read by gsd.hoomd).
"$GELSIM" compress --preset quick --fidelity fast --steps 1 --phi-max 0.2 --seeds 2,1 --out "$WORK/snap" > /dev/null 2>&1 \
  || fail "ensemble with snapshots"
"$GELSIM" export "$WORK/snap" --out "$WORK/frames/rows.gsd" > "$WORK/export.out" 2> "$WORK/export.log" \
  || fail "export of the ensemble's folder exited $?: $(cat "$WORK/export.log")"
/usr/bin/python3 - "$WORK" <<'PY' || fail "the members' GSD files"
import json, sys, gsd.hoomd
work = sys.argv[1]
for seed in (2, 1):
    rows = [r for r in json.load(open(f"{work}/snap/seed_{seed}/curve.json"))["rows"] if r.get("snapshot")]
    with gsd.hoomd.open(f"{work}/frames/rows_seed_{seed}.gsd", "rb") as frames:
        assert len(frames) == len(rows) >= 2, (seed, len(frames), len(rows))
        assert [int(f.configuration.step) for f in frames] == [int(r.get("steps", 0)) for r in rows], seed
listed = open(f"{work}/export.out").read().split()
assert listed == [f"{work}/frames/rows_seed_2.gsd", f"{work}/frames/rows_seed_1.gsd"], listed
PY
set +e; "$GELSIM" export "$WORK/snap" "$WORK/snap/seed_1" --out "$WORK/both.gsd" > /dev/null 2> "$WORK/mixed.log"; code=$?; set -e
[ "$code" -eq 2 ] && grep -q "is an ensemble's folder: export it on its own" "$WORK/mixed.log" \
  || fail "an ensemble's folder mixed with other inputs: exit $code, $(cat "$WORK/mixed.log")"

# 2. Stopped by SIGTERM once every member has a row, resumed: the same rows as uninterrupted.
LONG=(--preset quick --fidelity fast --steps 5 --phi-max 0.4 --no-snapshots --checkpoint-seconds 0.2)
"$GELSIM" compress "${LONG[@]}" --seeds 5-6 --jobs 2 --out "$WORK/stop" --progress-file "$WORK/stop.jsonl" 2> "$WORK/stop.log" &
pid=$!
for _ in $(seq 600); do
  rows=$(grep -c '"type":"row"' "$WORK/stop.jsonl" 2>/dev/null || true)
  [ "${rows:-0}" -ge 4 ] && break   # row 0 and row 1 of both members
  kill -0 "$pid" 2>/dev/null || break
  sleep 0.1
done
kill -TERM "$pid" 2>/dev/null || fail "the ensemble finished before it could be stopped (make LONG longer)"
set +e; wait "$pid"; code=$?; set -e
[ "$code" -eq 4 ] || fail "a stopped ensemble exits 4, got $code: $(tail -3 "$WORK/stop.log")"
grep -q '"type":"stopped"' "$WORK/stop.jsonl" || fail "no stopped line in the progress file"
"$GELSIM" compress --resume "$WORK/stop" --no-snapshots > /dev/null 2> "$WORK/resume.log" || fail "resume exited $?: $(tail -3 "$WORK/resume.log")"
"$GELSIM" compress "${LONG[@]}" --seeds 5-6 --jobs 1 --out "$WORK/whole" > /dev/null 2>&1 || fail "uninterrupted ensemble"
for seed in 5 6; do
  same_rows "$WORK/stop/seed_$seed/curve.json" "$WORK/whole/seed_$seed/curve.json" || fail "resumed member $seed differs"
done

# 3. Bad input: exit 2 and nothing written.
for bad in "3-1" "x" "1-2a" "1,,2"; do
  set +e; "$GELSIM" compress "${SMALL[@]}" --seeds "$bad" --out "$WORK/bad" > /dev/null 2> "$WORK/bad.log"; code=$?; set -e
  [ "$code" -eq 2 ] || fail "--seeds '$bad' exited $code, expected 2"
  grep -q -- "--seeds" "$WORK/bad.log" || fail "the error for --seeds '$bad' does not name the option"
  [ ! -e "$WORK/bad" ] || fail "--seeds '$bad' wrote $WORK/bad"
done
set +e; "$GELSIM" compress "${SMALL[@]}" --seeds 1-2 > /dev/null 2>&1; code=$?; set -e
[ "$code" -eq 2 ] || fail "an ensemble without --out exited $code, expected 2"
echo "ok"
