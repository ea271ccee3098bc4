#!/usr/bin/env bash
# gelsim study end to end with the real gelsim on tiny scenes: two ensembles of three seeds run
# into OUT/<ensemble>/seed_<seed> and are analysed into OUT/study_analysis.json; the same command
# again runs nothing and gives the same analysis, also from a copy holding only each member's
# curve.json and structure.json; a SIGTERM stops it with exit 4 and the same
# command finishes it with the rows of an uninterrupted study; --analyse-only and bad input.
set -euo pipefail
GELSIM=${1:?usage: test_gelsim_study.sh GELSIM}
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
py=/usr/bin/python3

tiny='"generator": {"preset": "quick", "n_floc": 8, "n_clusters": 8, "lx": 30, "ly": 50}, "compression": {"fidelity": "fast", "steps": 3}'
cat > "$WORK/study.json" <<JSON
{"ensembles": [
  {"name": "bond1", "scene": {"bond": {"preset": "bond1"}, $tiny}, "seeds": [1, 2, 3]},
  {"name": "bond2", "scene": {"bond": {"preset": "bond2"}, $tiny}}]}
JSON

# 1. Run and analyse (bond2's seeds from --seeds).
"$GELSIM" study --file "$WORK/study.json" --seeds 3 --jobs 2 --bootstrap-samples 200 --out "$WORK/a" > "$WORK/a.out" 2> "$WORK/a.log" \
  || fail "study exited $?: $(tail -3 "$WORK/a.log")"
grep -q "study of 2 ensembles, 6 runs, 2 at a time" "$WORK/a.log" || fail "not 6 runs 2 at a time: $(head -2 "$WORK/a.log")"
[ "$(grep -c 'done in' "$WORK/a.log")" -eq 6 ] || fail "not 6 runs done"
# It ends with a summary: the members, each ensemble's headline numbers, where the figures and
# the analysis are.
grep -qx "members: 6 of 6 finished (6 run now, 0 already done)" "$WORK/a.out" || fail "no members line: $(cat "$WORK/a.out")"
for e in bond1 bond2; do
  grep -qx "$e: 3 seeds (95 % bootstrap intervals over seeds)" "$WORK/a.out" || fail "no summary of $e: $(cat "$WORK/a.out")"
  grep -qx "  figures: gelsim plot $WORK/a/$e  (draws them into $WORK/a/$e/plots)" "$WORK/a.out" || fail "$e: where are its figures"
done
[ "$(tail -1 "$WORK/a.out")" = "analysis (every observable, every row): $WORK/a/study_analysis.json" ] \
  || fail "the analysis path is not the last line: $(tail -1 "$WORK/a.out")"
$py - "$WORK/a" <<'PY' || fail "study analysis"
import json, os, sys
out = sys.argv[1]
analysis = json.load(open(os.path.join(out, "study_analysis.json")))
assert analysis["format"] == "gel.study-analysis.v1" and analysis["bootstrap_samples"] == 200, analysis["format"]
assert [e["name"] for e in analysis["ensembles"]] == ["bond1", "bond2"]
for e in analysis["ensembles"]:
    assert e["members"] == 3 and e["seeds"] == [1, 2, 3], (e["name"], e["members"], e["seeds"])
    curves = [json.load(open(os.path.join(out, e["name"], f"seed_{s}", "curve.json"))) for s in (1, 2, 3)]
    assert curves[0]["parameters"]["bond"]["preset"] == e["name"]
    for k, row in enumerate(e["rows"]):
        mean = sum(c["rows"][k]["P"] for c in curves) / 3
        assert abs(row["P"]["value"] - mean) <= 1e-12 * max(1.0, abs(mean)), (k, row["P"], mean)
    assert e["fractal_dimension_initial"]["n"] == 3  # from the members' snapshots
PY

# 2. The same command again: nothing runs, the same analysis.
cp "$WORK/a/study_analysis.json" "$WORK/first.json"
"$GELSIM" study --file "$WORK/study.json" --seeds 3 --bootstrap-samples 200 --out "$WORK/a" > "$WORK/again.out" 2> "$WORK/again.log" \
  || fail "the repeated study exited $?"
! grep -q "done in" "$WORK/again.log" || fail "a finished member ran again"
grep -qx "members: 6 of 6 finished (0 run now, 6 already done)" "$WORK/again.out" || fail "again: $(head -1 "$WORK/again.out")"
same_analysis() {  # equal but for the time the structure analyses took
  $py - "$1" "$2" <<'PY'
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
for analysis in (a, b):
    for e in analysis["ensembles"]:
        e.pop("structure_seconds")
sys.exit(0 if a == b else "analyses differ")
PY
}
same_analysis "$WORK/first.json" "$WORK/a/study_analysis.json" || fail "the repeated analysis differs"
"$GELSIM" study --out "$WORK/a" --analyse-only --bootstrap-samples 200 > /dev/null 2>&1 || fail "--analyse-only"
same_analysis "$WORK/first.json" "$WORK/a/study_analysis.json" || fail "--analyse-only gives another analysis"

# 2b. Each member keeps its structure numbers (structure.json): a copy of the study with only
# curve.json and structure.json per member gives the same analysis, runs nothing, and a
# structure.json that does not fit its curve is recomputed, not believed.
$py - "$WORK/a" <<'PY' || fail "structure.json"
import json, os, sys
for ensemble in ("bond1", "bond2"):
    for seed in (1, 2, 3):
        d = os.path.join(sys.argv[1], ensemble, f"seed_{seed}")
        s = json.load(open(os.path.join(d, "structure.json")))
        rows = json.load(open(os.path.join(d, "curve.json")))["rows"]
        assert s["format"] == "gel.member-structure.v1", s["format"]
        assert [r["k"] for r in s["rows"]] == [r["k"] for r in rows], (d, s["rows"])
        assert isinstance(s["D_f_initial"], float) and 1.0 < s["D_f_initial"] < 2.0, s["D_f_initial"]
        assert any(isinstance(r["xi_05"], float) for r in s["rows"]), s["rows"]
PY
mkdir -p "$WORK/kept"
cp "$WORK/a/study.json" "$WORK/kept/"
for d in "$WORK"/a/bond*/seed_*; do
  target="$WORK/kept/$(basename "$(dirname "$d")")/$(basename "$d")"
  mkdir -p "$target" && cp "$d/curve.json" "$d/structure.json" "$target/"
done
"$GELSIM" study --file "$WORK/study.json" --seeds 3 --bootstrap-samples 200 --out "$WORK/kept" > /dev/null 2> "$WORK/kept.log" \
  || fail "the study from curves and structure files exited $?"
! grep -q "done in" "$WORK/kept.log" || fail "a member with its curve and structure file ran again"
same_analysis "$WORK/first.json" "$WORK/kept/study_analysis.json" || fail "the analysis from structure files differs"
$py - "$WORK/kept/bond1/seed_1/structure.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
s["rows"] = s["rows"][:-1]  # no longer the curve's rows
json.dump(s, open(sys.argv[1], "w"))
PY
"$GELSIM" study --out "$WORK/kept" --analyse-only --bootstrap-samples 200 > /dev/null 2>&1 || fail "--analyse-only with a bad structure file"
$py - "$WORK/kept/study_analysis.json" <<'PY' || fail "a structure file that does not fit its curve was believed"
import json, sys
e = json.load(open(sys.argv[1]))["ensembles"][0]
# Recomputed from snapshots that this copy lacks: that member has no D_f now.
assert e["fractal_dimension_initial"]["n"] == 2, e["fractal_dimension_initial"]
PY

# 3. SIGTERM once the first row is out, then the same command: the rows of the uninterrupted study.
"$GELSIM" study --file "$WORK/study.json" --seeds 3 --jobs 1 --bootstrap-samples 200 --out "$WORK/b" > /dev/null 2> "$WORK/b.log" &
pid=$!
for _ in $(seq 1 600); do grep -q " k 1 " "$WORK/b.log" 2>/dev/null && break; sleep 0.05; done
kill -TERM "$pid"
set +e; wait "$pid"; code=$?; set -e
resumed="finished before the signal"
if [ "$code" -eq 4 ]; then
  resumed="stopped by SIGTERM and resumed"
  grep -q "the same command resumes the study" "$WORK/b.log" || fail "no resume hint after SIGTERM"
  "$GELSIM" study --file "$WORK/study.json" --seeds 3 --bootstrap-samples 200 --out "$WORK/b" > /dev/null 2>&1 || fail "resumed study"
else
  [ "$code" -eq 0 ] || fail "study under SIGTERM exited $code"  # it was faster than the signal
fi
$py - "$WORK/a" "$WORK/b" <<'PY' || fail "the resumed study differs from the uninterrupted one"
import json, os, sys
a, b = sys.argv[1:3]
for ensemble in ("bond1", "bond2"):
    for seed in (1, 2, 3):
        rows = [json.load(open(os.path.join(d, ensemble, f"seed_{seed}", "curve.json")))["rows"] for d in (a, b)]
        strip = lambda rs: [{k: v for k, v in r.items() if k != "wall_seconds"} for r in rs]
        assert strip(rows[0]) == strip(rows[1]), (ensemble, seed)
PY

# 4. Bad input: exit 2 naming the option, before anything runs.
expect2() {  # expect2 PATTERN -- args...
  local pattern=$1 code=0
  shift 2
  "$GELSIM" study "$@" > /dev/null 2> "$WORK/err.txt" || code=$?
  [ "$code" -eq 2 ] || fail "gelsim study $*: exit $code, expected 2: $(cat "$WORK/err.txt")"
  grep -q -- "$pattern" "$WORK/err.txt" || fail "gelsim study $*: stderr lacks '$pattern': $(cat "$WORK/err.txt")"
}
expect2 "unknown study preset 'nope'" -- --preset nope --out "$WORK/c"
expect2 "holds no study" -- --out "$WORK/none" --analyse-only
expect2 "--out" -- --preset quick
echo '{"ensembles": [{"name": "a/b", "scene": {}}]}' > "$WORK/bad.json"
expect2 "ensembles\[0\].name" -- --file "$WORK/bad.json" --seeds 2 --out "$WORK/d"
echo '{"ensembles": [{"name": "x", "scene": {}}]}' > "$WORK/noseeds.json"
expect2 "seeds" -- --file "$WORK/noseeds.json" --out "$WORK/e"
[ ! -e "$WORK/d/bond1" ] && [ ! -e "$WORK/e/x" ] || fail "a refused study ran something"
"$GELSIM" study --list-presets | grep -q "^paper (fidelity quasistatic): bond1 x10 bond2 x10$" || fail "--list-presets"
echo "ok: gelsim study runs, analyses, skips finished members, refuses bad input; SIGTERM: $resumed"
