#!/usr/bin/env bash
# The real gelsim's failure paths for one run, end to end: a numerical instability exits 3 with a
# `failed` progress line and no curve passed off as finished; SIGTERM exits 4 with a `stopped`
# line and a checkpoint; --resume from it gives the rows of an uninterrupted run bit for bit; a
# SIGTERM during a long gel generation is honoured at once; a bad scene exits 2 naming the field;
# errors name what was typed (a command, a flag's value, a scene field, a GSD file); a used --out
# is refused unless --resume or --overwrite, which clears only a run's files.
set -euo pipefail
GELSIM=${1:?usage: test_gelsim_failures.sh GELSIM}
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

# 1. Instability: dt at half the shortest period puts the bond spring far past Verlet's limit.
cat > "$WORK/unstable.json" <<'JSON'
{"preset": "quick", "integration": {"dt_fraction": 0.5}, "compression": {"fidelity": "fast", "steps": 2, "phi_max": 0.2}}
JSON
set +e
"$GELSIM" compress --scene "$WORK/unstable.json" --out "$WORK/unstable" --no-snapshots \
  --progress-file "$WORK/unstable.jsonl" > "$WORK/unstable.out" 2>&1
code=$?
set -e
[ "$code" -eq 3 ] || fail "an unstable run exits 3, got $code: $(tail -2 "$WORK/unstable.out")"
grep -q "numerical instability" "$WORK/unstable.out" || fail "no instability message on stderr"
python3 - "$WORK/unstable.jsonl" <<'PY' || fail "progress file of the unstable run"
import json, sys
lines = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
last = lines[-1]
assert last["type"] == "failed" and last["kind"] == "instability", last
assert "reduce integration.dt_fraction" in last["error"], last
assert not any(l["type"] == "done" for l in lines), "an unstable run reported done"
PY

# 2. SIGTERM after the first rows: exit 4, a stopped line, a checkpoint; --resume finishes it.
LONG=(--preset quick --fidelity fast --steps 5 --phi-max 0.4 --no-snapshots --checkpoint-seconds 0.2)
"$GELSIM" compress "${LONG[@]}" --seed 7 --out "$WORK/stop" --progress-file "$WORK/stop.jsonl" > /dev/null 2> "$WORK/stop.log" &
pid=$!
for _ in $(seq 600); do
  rows=$(grep -c '"type":"row"' "$WORK/stop.jsonl" 2>/dev/null || true)
  [ "${rows:-0}" -ge 2 ] && break
  kill -0 "$pid" 2>/dev/null || break
  sleep 0.1
done
kill -TERM "$pid" 2>/dev/null || fail "the run finished before it could be stopped (make LONG longer)"
set +e; wait "$pid"; code=$?; set -e
[ "$code" -eq 4 ] || fail "a stopped run exits 4, got $code: $(tail -3 "$WORK/stop.log")"
tail -1 "$WORK/stop.jsonl" | grep -q '"type":"stopped"' || fail "the last progress line is not 'stopped': $(tail -1 "$WORK/stop.jsonl")"
[ -s "$WORK/stop/checkpoint.bin" ] || fail "no checkpoint after SIGTERM"
"$GELSIM" compress --resume "$WORK/stop" --no-snapshots > /dev/null 2> "$WORK/resume.log" || fail "resume exited $?: $(tail -3 "$WORK/resume.log")"
"$GELSIM" compress "${LONG[@]}" --seed 7 --out "$WORK/whole" > /dev/null 2>&1 || fail "uninterrupted run"
python3 - "$WORK/stop/curve.json" "$WORK/whole/curve.json" <<'PY' || fail "resumed run differs from the uninterrupted one"
import json, sys
a, b = (json.load(open(p))["rows"] for p in sys.argv[1:3])
strip = lambda rows: [{k: v for k, v in r.items() if k != "wall_seconds"} for r in rows]
assert len(a) == 6, f"{len(a)} rows after resume"
assert strip(a) == strip(b), "rows differ"
PY

# 3. SIGTERM while a huge dilute box is still being generated (minutes of random walk): the
#    generator honours the stop, exit 4 within seconds, and the message says nothing can resume.
echo '{"preset": "quick", "generator": {"lx": 5000, "ly": 5000}}' > "$WORK/bigbox.json"
"$GELSIM" compress --scene "$WORK/bigbox.json" --out "$WORK/bigbox" --no-snapshots \
  --progress-file "$WORK/bigbox.jsonl" > /dev/null 2> "$WORK/bigbox.log" &
pid=$!
for _ in $(seq 100); do grep -q generating "$WORK/bigbox.jsonl" 2>/dev/null && break; sleep 0.05; done
sleep 0.5
kill -TERM "$pid" 2>/dev/null || fail "the big box finished generating at once (make it bigger)"
start=$(date +%s%N)
set +e; wait "$pid"; code=$?; set -e
elapsed_ms=$(( ($(date +%s%N) - start) / 1000000 ))
[ "$code" -eq 4 ] || fail "a run stopped while generating exits 4, got $code: $(tail -2 "$WORK/bigbox.log")"
[ "$elapsed_ms" -lt 10000 ] || fail "the generator took ${elapsed_ms} ms to honour SIGTERM"
grep -q "before the gel was generated" "$WORK/bigbox.log" || fail "stop message: $(tail -1 "$WORK/bigbox.log")"

# 4. A bad scene: exit 2, the field named, nothing run.
echo '{"preset": "quick", "integration": {"dt_fraction": -1}}' > "$WORK/bad.json"
set +e
"$GELSIM" compress --scene "$WORK/bad.json" --out "$WORK/bad" > "$WORK/bad.out" 2>&1
code=$?
set -e
[ "$code" -eq 2 ] || fail "a bad scene exits 2, got $code: $(cat "$WORK/bad.out")"
grep -q "dt_fraction" "$WORK/bad.out" || fail "the error does not name the field: $(cat "$WORK/bad.out")"
[ ! -e "$WORK/bad/curve.json" ] || fail "a refused scene wrote a curve"
# 5. Integers are validated, not wrapped or silently defaulted; a progress file inside a run
#    directory that does not exist yet (the README's example) works.
#    Seeds: one rule (gel/seed.hpp, geld's too), in the same words, for every command that takes one.
for bad in "compress --seed -1" "compress --steps 0" "compress --seed 0" "compress --seeds 0-2" "generate --seed -1" \
           "generate --seed 0" "generate --seed 9223372036854775808"; do
  set +e
  # shellcheck disable=SC2086
  "$GELSIM" $bad --preset quick --out "$WORK/int" > "$WORK/int.out" 2>&1
  code=$?
  set -e
  [ "$code" -eq 2 ] || fail "'$bad' exits 2, got $code: $(cat "$WORK/int.out")"
  flag=${bad#* }
  grep -q -- "${flag%% *}" "$WORK/int.out" || fail "'$bad' refused without naming the flag: $(cat "$WORK/int.out")"
  [[ $bad != *seed* ]] || grep -qF "is not a seed; seeds are whole numbers from 1 to 9223372036854775807 (2^63-1)" \
    "$WORK/int.out" || fail "'$bad' refused without the seed rule: $(cat "$WORK/int.out")"
  [ ! -e "$WORK/int" ] || fail "'$bad' wrote $WORK/int"
done
"$GELSIM" compress --preset quick --fidelity fast --steps 2 --phi-max 0.2 --no-snapshots --out "$WORK/runs/b1" \
  --progress-file "$WORK/runs/b1/progress.jsonl" > /dev/null 2>&1 || fail "a progress file in the new run directory"
grep -q '"type":"done"' "$WORK/runs/b1/progress.jsonl" || fail "no done line in the progress file"

# expect CODE TEXT -- gelsim-args...: the exit code, and TEXT (fixed) on stderr.
expect() {
  local code=$1 text=$2 status=0
  shift 3
  "$GELSIM" "$@" > "$WORK/expect.out" 2> "$WORK/expect.err" || status=$?
  [ "$status" -eq "$code" ] || fail "gelsim $* exited $status, expected $code: $(cat "$WORK/expect.err")"
  grep -qF -- "$text" "$WORK/expect.err" || fail "gelsim $*: stderr lacks '$text': $(cat "$WORK/expect.err")"
}
# 6. Errors in the product's words, naming what was typed and what is allowed.
expect 2 "gelsim: unknown command 'frobnicate': the commands are analyze, " -- frobnicate
expect 2 "gelsim: --jobs: must be a whole number >= 0, got 'x'" -- compress --jobs x
echo '{"preset": "quick", "compression": {"stepz": 2}}' > "$WORK/stepz.json"
expect 2 "gelsim: invalid argument: scene.compression.stepz: no such field; did you mean 'steps'?" -- compress --scene "$WORK/stepz.json"
"$GELSIM" generate --preset quick --seed 1 --out "$WORK/gel.json" > /dev/null
cp "$WORK/gel.json" "$WORK/gel.gsd"
# A .gsd goes to the GSD reader (tests/cli/test_import.sh), which says the file is none.
expect 2 "gelsim: invalid argument: path: '$WORK/gel.gsd': not a GSD file (no GSD header)" -- compress --gel "$WORK/gel.gsd"

# 7. A used --out: refused unless --resume or --overwrite, which removes the earlier run's files
#    (its trajectory and snapshots past the new last row stayed beside the new curve) and only
#    where gelsim wrote a run. Without --out the run says that it writes nothing.
SHORT=(--preset quick --fidelity fast --phi-max 0.2)
"$GELSIM" compress "${SHORT[@]}" --steps 3 --trajectory-every 20000 --out "$WORK/used" > /dev/null 2>&1 || fail "the first run"
[ -f "$WORK/used/trajectory.gsd" ] && [ -f "$WORK/used/snapshots/k_003.pb" ] || fail "the first run left no trajectory or k_003"
cp "$WORK/used/curve.json" "$WORK/first_curve.json"
expect 2 "gelsim: invalid argument: --out: '$WORK/used' holds an earlier run (checkpoint.bin, checkpoint.prev.bin, curve.csv, curve.json, profiles.csv, snapshots, trajectory.gsd): continue it with --resume $WORK/used, replace it with --overwrite, or choose another --out" \
  -- compress "${SHORT[@]}" --steps 2 --out "$WORK/used"
cmp -s "$WORK/used/curve.json" "$WORK/first_curve.json" || fail "a refused run changed the earlier curve"
expect 0 "gelsim: --overwrite: removed the earlier run's checkpoint.bin, checkpoint.prev.bin, curve.csv, curve.json, profiles.csv, snapshots, trajectory.gsd from $WORK/used" \
  -- compress "${SHORT[@]}" --steps 2 --out "$WORK/used" --overwrite
[ ! -e "$WORK/used/trajectory.gsd" ] || fail "--overwrite left the earlier run's trajectory"
[ "$(ls "$WORK/used/snapshots")" = "$(printf 'k_000.pb\nk_001.pb\nk_002.pb')" ] || fail "snapshots after --overwrite: $(ls "$WORK/used/snapshots")"
expect 2 "--overwrite: starts the run afresh, --resume continues it" -- compress --resume "$WORK/used" --overwrite
mkdir -p "$WORK/photos/snapshots"
echo "mine" > "$WORK/photos/snapshots/beach.jpg"
expect 2 "out_dir: '$WORK/photos' holds snapshots but no checkpoint, curve.json or ensemble.json that gelsim wrote" \
  -- compress "${SHORT[@]}" --steps 2 --out "$WORK/photos" --overwrite
[ -f "$WORK/photos/snapshots/beach.jpg" ] || fail "--overwrite removed a folder that was not a run's"
"$GELSIM" compress "${SHORT[@]}" --steps 2 --seeds 1-2 --out "$WORK/ens" > /dev/null 2>&1 || fail "an ensemble"
expect 2 "'$WORK/ens' holds an earlier run (ensemble.json, seed_1, seed_2)" -- compress "${SHORT[@]}" --steps 2 --seeds 1-2 --out "$WORK/ens"
expect 0 "gelsim: no --out DIR: the curve is printed at the end, and no curve.json, snapshot or checkpoint is written" \
  -- compress "${SHORT[@]}" --steps 2
echo "gelsim failure paths: ok"
