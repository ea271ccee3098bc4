#!/usr/bin/env bash
# End to end with the real binaries: geld on a free loopback port with its SQLite file in a
# temporary directory, driven by gelctl and by the Python client.
#   submit --watch / status --json / curve --json|--csv / list / logs / cancel of a running job
#   bad input: exit codes and one-line messages naming the field (scene JSON, --set, --where), and
#     the daemon keeps serving
#   a job the engine fails (numerical instability): watch exits 3 (as for a cancelled job)
#   SIGKILL mid-job, restart: the job resumes and ends with the curve of an uninterrupted run
#   studies: study submit --file --watch, list, show, analysis, refusals
#   remote mode: --listen 0.0.0.0 needs --token-file; calls without the token UNAUTHENTICATED
#   the command line: an unknown command, --server without a port, no geld at the address, a
#     --workers that is not a number: each said in one line naming what was typed
#
#   gelctl_e2e.sh BUILD_DIR
set -euo pipefail
build=$(cd "$1" && pwd)
source_dir=$(cd "$(dirname "$0")/../.." && pwd)
geld=$build/server/geld
gelctl=$build/client/gelctl
py=/usr/bin/python3
work=$(mktemp -d /tmp/gelctl-e2e.XXXXXX)
pids=()
cleanup() {
  for pid in "${pids[@]}"; do kill -KILL "$pid" 2>/dev/null || true; done
  rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
free_port() { $py -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1]); s.close()'; }

# start_geld DATA_DIR PORT [extra flags]: sets geld_pid, waits until it answers.
start_geld() {
  local data=$1 port=$2
  shift 2
  "$geld" --listen "127.0.0.1:$port" --data-dir "$data" --log-level info --workers 2 "$@" >>"$data.log" 2>&1 &
  geld_pid=$!
  pids+=("$geld_pid")
  for _ in $(seq 1 300); do
    "$gelctl" --server "127.0.0.1:$port" list >/dev/null 2>&1 && return 0
    kill -0 "$geld_pid" 2>/dev/null || { cat "$data.log" >&2; fail "geld did not start"; }
    sleep 0.05
  done
  fail "geld did not answer"
}

port=$(free_port)
server=127.0.0.1:$port
data=$work/data
start_geld "$data" "$port"
ctl() { "$gelctl" --server "$server" "$@"; }
TINY=(--preset quick --fidelity fast --set generator.n_floc=8 --set generator.n_clusters=8
      --set generator.lx=30 --set generator.ly=50 --set compression.steps=3)

# ---- submit --watch, status, curve ---------------------------------------------------------
ctl submit "${TINY[@]}" --seed 1 --name e2e --label suite=e2e --watch >"$work/watch.txt" || fail "submit --watch"
job=$(head -n 1 "$work/watch.txt")
[[ $job =~ ^job-[0-9]+$ ]] || fail "first line of submit is not a job id: $job"
grep -qxF "$job: succeeded" "$work/watch.txt" || fail "watch did not show success"
[ "$(grep -c '^  k' "$work/watch.txt")" -eq 4 ] || fail "watch did not show 4 rows"
# The store and the job files are not readable by other users, however geld was started.
[ "$(stat -c %a "$data/geld.sqlite")" = 600 ] || fail "geld.sqlite has mode $(stat -c %a "$data/geld.sqlite"), expected 600"
[ "$(stat -c %a "$data")" = 700 ] || fail "the data dir has mode $(stat -c %a "$data"), expected 700"
ctl status "$job" --json >"$work/status.json"
$py - "$work/status.json" "$("$geld" --version)" <<'PY' || fail "status --json"
import json, sys
job = json.load(open(sys.argv[1]))
assert job["state"] == "succeeded", job["state"]
assert job["rows"] == 4 and job["labels"] == {"suite": "e2e"} and job["name"] == "e2e"
assert job["program_version"] == sys.argv[2], (job.get("program_version"), sys.argv[2])
PY
ctl status "$job" | grep -qxF "  program $("$geld" --version)" || fail "status does not show the program version"
ctl curve "$job" --json >"$work/curve.json"
$py - "$work/curve.json" <<'PY' || fail "curve --json"
import json, sys
curve = json.load(open(sys.argv[1]))
rows = curve["rows"]
assert len(rows) == 4, len(rows)
for row in rows:
    for key in ("phi", "P", "P_top", "P_bot", "contact_number"):
        assert key in row, key
assert rows[-1]["phi"] > rows[0]["phi"]
PY
ctl curve "$job" --csv --out "$work/curve.csv"
[ "$(wc -l <"$work/curve.csv")" -eq 5 ] || fail "curve --csv: expected a header and 4 rows"
table=$(ctl curve "$job") || fail "curve (table)"
grep -qxF "# job $job (succeeded), seed 1, 64 particles, 4 rows" <<<"$table" \
  || fail "curve table header is not the 64-particle, 4-row job: $(head -n 1 <<<"$table")"
[ "$(grep -cE '^ +[0-9]+ ' <<<"$table")" -eq 4 ] || fail "curve table does not have 4 rows"
ctl curve "$job" --png "$work/curve.png" >/dev/null || fail "curve --png"
[ "$(head -c 4 "$work/curve.png" | tail -c 3)" = PNG ] || fail "curve --png did not write a PNG"
# Each listing captured first: a gelctl that fails must not pass for "job not listed".
listed=$(ctl list --label suite=e2e) || fail "list --label"
grep -qE "^$job +succeeded +e2e " <<<"$listed" || fail "list --label does not show $job: $listed"
listed=$(ctl list --state succeeded) || fail "list --state succeeded"
grep -qE "^$job +succeeded " <<<"$listed" || fail "list --state succeeded does not show $job: $listed"
listed=$(ctl list --state running) || fail "list --state running"
if grep -q "^$job " <<<"$listed"; then fail "list --state running shows a finished job: $listed"; fi
analysis=$(ctl analysis "$job") || fail "analysis"
grep -qx "members: 1" <<<"$analysis" || fail "analysis summary does not say 1 member: $analysis"
grep -qE "^(power law P = C phi\^lambda: lambda = |power law: none \()" <<<"$analysis" || fail "analysis has no power-law line: $analysis"
ctl analysis "$job" --json >"$work/analysis.json" || fail "analysis --json"
$py - "$work/analysis.json" "$work/curve.json" <<'PY' || fail "analysis --json"
import json, sys
analysis, curve = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
assert analysis["members"] == 1
assert analysis["rows"]["P"]["mean"] == [row["P"] for row in curve["rows"]], (analysis["rows"]["P"], curve["rows"])
PY
logs=$(ctl logs "$job") || fail "logs"
grep -qE " member 0 finished with 4 rows$" <<<"$logs" || fail "logs lack the member's end: $logs"
listed=$(ctl query --label suite=e2e) || fail "query"
grep -qE "^$job +e2e +bond1 " <<<"$listed" || fail "query does not show $job: $listed"
set +e; ctl query --where 'generator.lx>=abc' > /dev/null 2> "$work/where.err"; code=$?; set -e
[ "$code" -eq 2 ] && grep -q -- "--where" "$work/where.err" || fail "a non-numeric --where bound: exit $code, $(cat "$work/where.err")"
ctl watch "$job" >/dev/null || fail "watch of a succeeded job exited non-zero"
echo "ok: submit --watch, status --json, curve --json/--csv/--png, list, logs, query ($job)"

# ---- run cache: the id first, the hit said, the new labels on the job ----------------------
ctl submit "${TINY[@]}" --seed 1 --label study=B --name mine >"$work/hit.txt" 2>"$work/hit.err" \
  || fail "submit of a scene that already ran: $(cat "$work/hit.err")"
[ "$(head -n 1 "$work/hit.txt")" = "$job" ] || fail "a cache hit's first line is not $job: $(cat "$work/hit.txt")"
listed=$(ctl list --label study=B) || fail "list --label study=B"
grep -qE "^$job +succeeded +e2e " <<<"$listed" || fail "list --label study=B does not show the hit's job $job: $listed"
grep -qF "cache hit of $job" "$work/hit.err" || fail "a cache hit does not say so: $(cat "$work/hit.err")"
echo "ok: a cache hit of $job prints its id, says so, and its labels are the job's"

# ---- bad input: exit codes and messages -----------------------------------------------------
expect() {  # expect CODE PATTERN -- command...
  local code=$1 pattern=$2 status=0
  shift 3
  "$@" >"$work/out.txt" 2>"$work/err.txt" || status=$?
  [ "$status" -eq "$code" ] || fail "$* exited $status, expected $code: $(cat "$work/err.txt")"
  grep -q -- "$pattern" "$work/err.txt" || fail "$*: stderr lacks '$pattern': $(cat "$work/err.txt")"
  [ "$(wc -l <"$work/err.txt")" -eq 1 ] || fail "$*: more than one line on stderr"
}
echo '{"preset": "quick", ' >"$work/broken.json"
expect 2 "INVALID_ARGUMENT: scene_json: not JSON: parse error at line 2, column 1: " -- ctl submit --scene "$work/broken.json"
# Said in the product's words, naming the field: protobuf's parser answered these with "Cannot find
# field", "invalid value \"nan\" for type TYPE_DOUBLE" and an empty table for a misspelt query.
expect 2 "INVALID_ARGUMENT: scene.compression.stepz: no such field; did you mean 'steps'?" -- \
  ctl submit --preset quick --set compression.stepz=4
expect 2 'INVALID_ARGUMENT: scene.compression.v_wall: must be a finite number, got "nan"' -- \
  ctl submit --preset quick --set compression.v_wall=nan
expect 2 'INVALID_ARGUMENT: scene.compression.v_wall: must be a finite number, got "inf"' -- \
  ctl submit --preset quick --set compression.v_wall=inf
expect 2 "INVALID_ARGUMENT: parameters\[0\].field: 'generator.nosuch': no such field (generator has preset, lx," -- \
  ctl query --where generator.nosuch=1
expect 2 "INVALID_ARGUMENT: scene.preset" -- ctl submit --preset nope
expect 2 "INVALID_ARGUMENT: scene.generator.lx" -- ctl submit --preset quick --set generator.lx=-5
expect 2 "INVALID_ARGUMENT: scene.compression.w0" -- ctl submit --preset quick --set compression.w0=NaN
expect 1 "RESOURCE_EXHAUSTED: scene.generator" -- ctl submit --preset quick --set generator.n_floc=1073741824
expect 1 "NOT_FOUND" -- ctl status job-424242
expect 1 "FAILED_PRECONDITION" -- ctl cancel "$job"
expect 2 "seeds" -- ctl submit --preset quick --seeds 3-1
expect 2 "INVALID_ARGUMENT: labels: key 'suite' is 'e2e' on $job" -- ctl submit "${TINY[@]}" --seed 1 --label suite=other
expect 2 "submit" -- ctl submit
ctl status "$job" >/dev/null || fail "geld stopped serving after bad input"
echo "ok: bad input gets exit 2/1 with the status code and the field"
# The command line and the address: what was typed, and where to look (no geld needed).
expect 2 "gelctl: unknown command 'frobnicate': the commands are submit, list, " -- "$gelctl" frobnicate
expect 2 "gelctl: --server: '127.0.0.1' is not HOST:PORT (no port)" -- "$gelctl" --server 127.0.0.1 list
expect 2 "gelctl: GELD_SERVER: 'localhost' is not HOST:PORT (no port)" -- env GELD_SERVER=localhost "$gelctl" list
dead_port=$(free_port)
expect 1 "gelctl: UNAVAILABLE: .* (no geld answers at 127.0.0.1:$dead_port: start geld there, or give its address with --server HOST:PORT or GELD_SERVER)" -- \
  "$gelctl" --server "127.0.0.1:$dead_port" --timeout 10 list
expect 2 "geld: --workers: must be a whole number >= 0, got 'abc'" -- "$geld" --workers abc
echo "ok: an unknown command, an address without a port, no geld there and a bad --workers are said in words"

# ---- studies: submit --file --watch, list, show, analysis, refusals ------------------------
cat >"$work/study.json" <<'JSON'
{"name": "e2e-study", "seed_count": 3, "rerun": true,
 "ensembles": [
  {"name": "bond1", "scene_json": "{\"preset\": \"quick\", \"generator\": {\"n_floc\": 8, \"n_clusters\": 8, \"lx\": 30, \"ly\": 50}, \"compression\": {\"fidelity\": \"fast\", \"steps\": 3}}"},
  {"name": "bond2", "scene_json": "{\"preset\": \"quick\", \"bond\": {\"preset\": \"bond2\"}, \"generator\": {\"n_floc\": 8, \"n_clusters\": 8, \"lx\": 30, \"ly\": 50}, \"compression\": {\"fidelity\": \"fast\", \"steps\": 3}}"}]}
JSON
ctl study submit --file "$work/study.json" --label suite=e2e --watch >"$work/study_watch.txt" || fail "study submit --watch"
study=$(head -n 1 "$work/study_watch.txt")
[[ $study =~ ^study-[0-9]+$ ]] || fail "first line of study submit is not a study id: $study"
grep -q "^\[bond1\] seed 3  k 3 " "$work/study_watch.txt" || fail "study watch lacks bond1's rows: $(cat "$work/study_watch.txt")"
grep -q "^\[bond2\] seed 1  k 0 " "$work/study_watch.txt" || fail "study watch lacks bond2's rows"
grep -q "^$study: succeeded" "$work/study_watch.txt" || fail "study watch did not end with success"
ctl study list | grep -qE "^$study +succeeded +e2e-study +2 " || fail "study list does not show $study: $(ctl study list)"
shown=$(ctl study show "$study") || fail "study show"
grep -qE "^  bond2 +job-[0-9]+ +succeeded +3/3 +12 " <<<"$shown" || fail "study show: $shown"
ctl study analysis "$study" | grep -q "^bond1: 3 seeds" || fail "study analysis summary"
ctl study analysis "$study" --json --bootstrap-samples 100 >"$work/study_analysis.json" || fail "study analysis --json"
$py - "$work/study_analysis.json" <<'PY' || fail "study analysis --json"
import json, sys
analysis = json.load(open(sys.argv[1]))
assert analysis["format"] == "gel.study-analysis.v1" and analysis["bootstrap_samples"] == 100, analysis["format"]
assert [e["name"] for e in analysis["ensembles"]] == ["bond1", "bond2"]
assert all(e["members"] == 3 and len(e["rows"]) == 4 for e in analysis["ensembles"])
PY
expect 1 "FAILED_PRECONDITION: study $study has already ended" -- ctl study cancel "$study"
expect 1 "NOT_FOUND" -- ctl study show study-424242
expect 2 "INVALID_ARGUMENT: preset: unknown study preset" -- ctl study submit --preset nope
expect 2 "give --preset or --file" -- ctl study submit
echo "ok: study submit --file --watch, list, show, analysis, refusals ($study)"

# ---- cancel a running job ------------------------------------------------------------------
long=$(ctl submit --preset quick --seed 5) || fail "submit of the job to cancel"
state=none
for _ in $(seq 1 600); do
  state=$(ctl status "$long" --json | $py -c 'import json,sys; print(json.load(sys.stdin)["state"])') \
    || fail "status of $long"
  [ "$state" = running ] && break
  sleep 0.05
done
# A job cancelled while still queued would print "cancelled" too: it must have been running.
[ "$state" = running ] || fail "$long was not running before the cancel (state $state)"
cancelled=$(ctl cancel "$long") || fail "cancel of a running job"
[ "$cancelled" = "$long: cancelled" ] || fail "cancel of a running job printed '$cancelled'"
ctl status "$long" --json >"$work/cancelled.json" || fail "status of the cancelled job"
$py - "$work/cancelled.json" <<'PY' || fail "the cancelled job's status"
import json, sys
job = json.load(open(sys.argv[1]))
assert job["state"] == "cancelled", job["state"]
assert job["error"] == "cancelled while running", job["error"]
assert job["started"] != "-", job["started"]
PY
status=0
ctl watch "$long" >"$work/cancelled-watch.txt" || status=$?
[ "$status" -eq 3 ] || fail "watch of a cancelled job exited $status, expected 3"
echo "ok: cancel of a running job; watching it exits 3"

# ---- a job that fails: exit 3 from watch ---------------------------------------------------
# dt at half the shortest period: the engine's stability guard stops the run at once.
cat >"$work/unstable.json" <<'JSON'
{"preset": "quick", "integration": {"dt_fraction": 0.5}, "compression": {"fidelity": "fast", "steps": 2, "phi_max": 0.2}}
JSON
status=0
ctl submit --scene "$work/unstable.json" --watch >"$work/unstable.txt" 2>"$work/unstable.err" || status=$?
[ "$status" -eq 3 ] || fail "submit --watch of a failing job exited $status, expected 3: $(cat "$work/unstable.err")"
unstable=$(head -n 1 "$work/unstable.txt")
[[ $unstable =~ ^job-[0-9]+$ ]] || fail "first line of submit is not a job id: $unstable"
grep -qE "^$unstable: failed: .*reduce integration\.dt_fraction" "$work/unstable.txt" \
  || fail "watch did not show the instability: $(cat "$work/unstable.txt")"
status=0
ctl watch "$unstable" >"$work/unstable-watch.txt" || status=$?
[ "$status" -eq 3 ] || fail "watch of a failed job exited $status, expected 3"
grep -qE "^$unstable: failed \(256 particles, 1 seed, [0-9]+ rows so far\): .*reduce integration\.dt_fraction" \
  "$work/unstable-watch.txt" || fail "watch of a failed job: $(cat "$work/unstable-watch.txt")"
[ "$(ctl status "$unstable" --json | $py -c 'import json,sys; print(json.load(sys.stdin)["state"])')" = failed ] \
  || fail "status of the failed job is not failed"
ctl status "$job" >/dev/null || fail "geld stopped serving after a failed job"
echo "ok: a failing job: submit --watch and watch exit 3 with the engine's message"

# ---- the Python client ---------------------------------------------------------------------
$py "$source_dir/client/python/gel_client.py" --stubs "$build/client/python" --server "$server" \
  --preset quick --set compression.fidelity=fast --set generator.n_floc=8 --set generator.n_clusters=8 \
  --set generator.lx=30 --set generator.ly=50 --set compression.steps=3 --seed 1 --seed 2 >"$work/py.txt" \
  || { cat "$work/py.txt" >&2; fail "python client"; }
grep -q "JOB_STATE_SUCCEEDED" "$work/py.txt" || fail "python client did not see success"
echo "ok: python client (2-seed ensemble)"

# ---- SIGKILL mid-job, restart, same curve ---------------------------------------------------
KILLED=(--preset quick --fidelity fast --seed 3)
ctl submit "${KILLED[@]}" --watch >"$work/reference.txt" || fail "reference run"
reference=$(head -n 1 "$work/reference.txt")
ctl curve "$reference" --json >"$work/reference.json"
victim=$(ctl submit "${KILLED[@]}" --rerun)  # the reference above ran the same scene: no run cache here
rows=0
for _ in $(seq 1 2000); do
  rows=$(ctl status "$victim" --json | $py -c 'import json,sys; print(json.load(sys.stdin)["rows"])')
  [ "$rows" -ge 2 ] && break
  sleep 0.02
done
kill -KILL "$geld_pid"
wait "$geld_pid" 2>/dev/null || true
stored=$($py -c "import sqlite3,sys; print(sqlite3.connect('$data/geld.sqlite').execute(\"select count(*) from curve_rows where job_id='$victim'\").fetchone()[0])")
echo "killed geld with $stored of 7 rows of $victim stored"
# Killed mid-run, or the restart below resumes nothing and the check proves nothing.
[ "$stored" -ge 2 ] && [ "$stored" -lt 7 ] || fail "geld was not killed mid-job ($stored of 7 rows stored)"
t0=$(date +%s.%N)
start_geld "$data" "$port"
t1=$(date +%s.%N)
ctl watch "$victim" >"$work/resumed.txt" || { cat "$work/resumed.txt" >&2; fail "resumed job did not succeed"; }
t2=$(date +%s.%N)
ctl curve "$victim" --json >"$work/resumed.json"
$py - "$work/reference.json" "$work/resumed.json" <<'PY' || fail "resumed curve differs from the uninterrupted one"
import json, sys
a = json.load(open(sys.argv[1]))["rows"]
b = json.load(open(sys.argv[2]))["rows"]
assert len(a) == len(b) == 7, (len(a), len(b))
for x, y in zip(a, b):
    for key in ("k", "phi", "P", "P_top", "P_bot", "contact_number", "stored_energy", "steps"):
        assert x[key] == y[key], (x["k"], key, x[key], y[key])
PY
grep -qF "job $victim: was running; resumes from its checkpoint" "$data.log" \
  || fail "geld's log does not mention the resumption of $victim"
echo "ok: SIGKILL with $stored rows stored; restart answered in $(awk "BEGIN{printf \"%.2f\", $t1-$t0}") s," \
  "the job finished $(awk "BEGIN{printf \"%.2f\", $t2-$t1}") s later with the uninterrupted curve"

kill -TERM "$geld_pid"
wait "$geld_pid" || fail "geld exited non-zero on SIGTERM"

# ---- remote mode ---------------------------------------------------------------------------
status=0
"$geld" --listen "0.0.0.0:$(free_port)" --data-dir "$work/remote" >"$work/remote.log" 2>&1 || status=$?
[ "$status" -eq 2 ] || fail "geld on 0.0.0.0 without --token-file exited $status, expected 2"
echo "e2e-token-$$" >"$work/token"
chmod 644 "$work/token"
expect 2 "readable by others" -- "$geld" --listen "0.0.0.0:0" --token-file "$work/token" --data-dir "$work/remote"
chmod 600 "$work/token"
rport=$(free_port)
"$geld" --listen "0.0.0.0:$rport" --token-file "$work/token" --data-dir "$work/remote" >"$work/remote.log" 2>&1 &
geld_pid=$!
pids+=("$geld_pid")
for _ in $(seq 1 300); do
  "$gelctl" --server "127.0.0.1:$rport" --token-file "$work/token" list >/dev/null 2>&1 && break
  sleep 0.05
done
expect 1 "UNAUTHENTICATED" -- "$gelctl" --server "127.0.0.1:$rport" list
echo "wrong" >"$work/wrong"
expect 1 "UNAUTHENTICATED" -- "$gelctl" --server "127.0.0.1:$rport" --token-file "$work/wrong" submit --preset quick
"$gelctl" --server "127.0.0.1:$rport" --token-file "$work/token" list >/dev/null || fail "token refused"
GELD_TOKEN_FILE=$work/token "$gelctl" --server "127.0.0.1:$rport" list >/dev/null || fail "GELD_TOKEN_FILE refused"
kill -TERM "$geld_pid"
wait "$geld_pid" || fail "remote geld exited non-zero"
echo "ok: remote mode requires the token"
