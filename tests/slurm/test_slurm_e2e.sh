#!/usr/bin/env bash
# End to end against a real single-node Slurm:
#   1. start the test cluster (slurm_cluster.sh) - skip (exit 77) where it cannot start;
#   2. geld --executor threads: `gelctl submit --preset quick --seeds 1,2 --watch`, its curve;
#   3. geld --executor slurm (shared dir in the temp dir): the same submission, followed to
#      SUCCEEDED; its curve must equal the threads one (every column but wall_seconds);
#   4. another slurm job, cancelled while its Slurm job runs: CANCELLED in geld and in Slurm;
#      and one during which geld stops (SIGTERM) and starts again: its Slurm job keeps running,
#      is followed again (not resubmitted) and the job SUCCEEDS; the Slurm ids are in SQLite;
#   5. prints the wall time submit -> SUCCEEDED of both executors and the Slurm overhead, on the
#      ensemble and (median of three) on a single-member job with ~2 s of compute;
#   6. stops geld (SIGTERM, exit 0 expected) and the Slurm daemons, by their pids.
#
#   test_slurm_e2e.sh GELD GELCTL GELSIM
set -euo pipefail

if [ $# -ne 3 ]; then
  echo "usage: $0 GELD GELCTL GELSIM" >&2
  exit 2
fi
geld=$(realpath "$1")
gelctl=$(realpath "$2")
gelsim=$(realpath "$3")
here=$(cd "$(dirname "$0")" && pwd)
cluster="$here/slurm_cluster.sh"

status=0
bash "$cluster" check || status=$?
if [ "$status" -eq 77 ]; then
  if [ "${GEL_REQUIRE_SLURM:-0}" = "1" ]; then
    echo "FAIL: test_slurm_e2e: GEL_REQUIRE_SLURM=1 but Slurm cannot start here (see above)"
    exit 1
  fi
  echo "SKIP: test_slurm_e2e: Slurm cannot start here (see above)"
  exit 77
elif [ "$status" -ne 0 ]; then
  exit "$status"
fi

work=$(mktemp -d /tmp/gel-slurm-e2e.XXXXXX)
chmod 0755 "$work"
geld_pids=()
cleanup() {
  local pid
  for pid in "${geld_pids[@]}"; do
    if kill -0 "$pid" 2>/dev/null; then kill -KILL "$pid" 2>/dev/null || true; fi
  done
  bash "$cluster" stop "$work/cluster" >/dev/null 2>&1 || true
  if [ -z "${GEL_KEEP_TEST_DIR:-}" ]; then rm -rf "$work"; else echo "kept $work"; fi
}
trap cleanup EXIT

fail() {
  echo "FAIL: $*" >&2
  local f
  for f in "$work"/geld-*.log; do
    [ -f "$f" ] || continue
    echo "----- $f (last 30 lines)" >&2
    tail -n 30 "$f" >&2
  done
  exit 1
}

free_port() {
  python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1]); s.close()'
}

now() { date +%s.%N; }

json_field() {  # json_field FIELD < json
  python3 -c 'import json,sys; print(json.load(sys.stdin)[sys.argv[1]])' "$1"
}

# start_geld NAME ARGS...: starts geld on a free port, waits until it answers; sets $server.
start_geld() {
  local name=$1
  shift
  local port
  port=$(free_port)
  "$geld" --listen "127.0.0.1:$port" --data-dir "$work/data-$name" --gelsim "$gelsim" "$@" \
    >"$work/geld-$name.log" 2>&1 &
  local pid=$!
  geld_pids+=("$pid")
  server="127.0.0.1:$port"
  local i
  for i in $(seq 1 200); do
    if "$gelctl" --server "$server" list >/dev/null 2>&1; then
      last_geld_pid=$pid
      return 0
    fi
    kill -0 "$pid" 2>/dev/null || fail "geld ($name) exited at start"
    sleep 0.1
  done
  fail "geld ($name) did not answer within 20 s"
}

stop_geld() {
  local pid=$1 rc=0
  kill -TERM "$pid"
  wait "$pid" || rc=$?
  [ "$rc" -eq 0 ] || fail "geld (pid $pid) exited $rc on SIGTERM"
}

# The ensemble: the quick preset. Under the sanitizers (GEL_SANITIZED=1, scripts/test.sh) the
# engine is several times slower and the Release run has already compared the physics, so the
# sanitized run checks the same path on a cheaper scene (fast fidelity, three targets).
ensemble_args=(--preset quick)
if [ "${GEL_SANITIZED:-0}" = "1" ]; then
  ensemble_args+=(--fidelity fast --set compression.steps=3)
  echo "note: sanitized build: the ensemble is quick with fast fidelity and 3 targets"
fi

# run_ensemble NAME: submit the ensemble (seeds 1,2) with --watch to $server; sets $job and $elapsed.
run_ensemble() {
  local name=$1 t0 t1 state
  t0=$(now)
  "$gelctl" --server "$server" submit "${ensemble_args[@]}" --seeds 1,2 --name "e2e-$name" --watch \
    >"$work/watch-$name.txt" 2>&1 || fail "gelctl submit --watch ($name) failed: $(tail -n 3 "$work/watch-$name.txt")"
  t1=$(now)
  job=$(head -n 1 "$work/watch-$name.txt" | tr -d '[:space:]')
  [ -n "$job" ] || fail "no job id printed ($name)"
  state=$("$gelctl" --server "$server" status "$job" --json | json_field state)
  [ "${state^^}" = "SUCCEEDED" ] || fail "job $job ($name) ended $state"
  elapsed=$(python3 -c "print(f'{$t1 - $t0:.2f}')")
  "$gelctl" --server "$server" curve "$job" --json >"$work/curve-$name.json" || fail "gelctl curve ($name)"
  echo "$name: job $job SUCCEEDED in ${elapsed} s (submit -> SUCCEEDED, 2 members)"
}

# time_small NAME: three single-member jobs whose compute is ~2 s (quick, fast fidelity, two
# targets), one after the other; prints the median submit -> SUCCEEDED seconds. With little
# compute in them, the difference between executors is the executor's own cost per job.
time_small() {
  local name=$1 i t0 t1 times=() small_job state
  for i in 1 2 3; do
    t0=$(now)
    "$gelctl" --server "$server" submit --preset quick --fidelity fast --set compression.steps=2 \
      --set compression.phi_max=0.2 --seed "$((10 + i))" --name "e2e-small-$name" --watch \
      >"$work/small-$name-$i.txt" 2>&1 || fail "small job ($name) failed: $(tail -n 3 "$work/small-$name-$i.txt")"
    t1=$(now)
    small_job=$(head -n 1 "$work/small-$name-$i.txt" | tr -d '[:space:]')
    state=$("$gelctl" --server "$server" status "$small_job" --json | json_field state)
    [ "${state^^}" = "SUCCEEDED" ] || fail "small job $small_job ($name) ended $state"
    times+=("$(python3 -c "print(f'{$t1 - $t0:.3f}')")")
  done
  python3 -c 'import statistics,sys; print(f"{statistics.median(map(float, sys.argv[1:])):.3f}")' "${times[@]}"
}

# ---- 1. Slurm --------------------------------------------------------------------------------
bash "$cluster" start "$work/cluster"
# shellcheck disable=SC1091
. "$work/cluster/env.sh"
# The first job after slurmctld starts waits for its first scheduling pass (a few seconds): a
# warm-up job keeps that out of the measurement.
warm=$(sbatch --parsable --output /dev/null --wrap true)
for _ in $(seq 1 100); do
  [ -z "$(squeue -h -j "$warm" -o %T 2>/dev/null)" ] && break
  sleep 0.1
done

# ---- 2. threads ------------------------------------------------------------------------------
start_geld threads --executor threads --workers 2
threads_pid=$last_geld_pid
run_ensemble threads
threads_job=$job
threads_seconds=$elapsed
threads_small=$(time_small threads)
stop_geld "$threads_pid"

# ---- 3. slurm --------------------------------------------------------------------------------
shared="$work/shared"
mkdir -p "$shared"
start_geld slurm --executor slurm --workers 2 --slurm-shared-dir "$shared" --slurm-gelsim "$gelsim" \
  --slurm-poll-interval 0.2 --slurm-max-requeues 2
slurm_pid=$last_geld_pid
run_ensemble slurm
slurm_job=$job
slurm_seconds=$elapsed
slurm_small=$(time_small slurm)

# Every member ran as its own Slurm job in the shared directory.
for member in 0 1; do
  dir=$(ls -d "$shared/$slurm_job/m$member-"* 2>/dev/null | head -n 1)
  [ -n "$dir" ] || fail "no member directory $shared/$slurm_job/m$member-*"
  ls "$dir"/slurm-*.out >/dev/null 2>&1 || fail "no slurm-<id>.out in $dir"
  grep -q '"type":"done"' "$dir/progress.jsonl" || fail "no done line in $dir/progress.jsonl"
done
"$gelctl" --server "$server" logs "$slurm_job" >"$work/logs-slurm.txt" 2>&1 || true
grep -q "Slurm job" "$work/logs-slurm.txt" || fail "the job's log names no Slurm job id"

# ---- curves equal, but for wall-clock columns --------------------------------------------------
python3 - "$work/curve-threads.json" "$work/curve-slurm.json" <<'EOF' || fail "the slurm curve differs from the threads curve"
import json, sys

TIMING = {"wall_seconds"}
IDENTITY = {"job_id", "id", "name", "created_unix_ms", "started_unix_ms", "finished_unix_ms"}

def strip(value):
    if isinstance(value, dict):
        return {k: strip(v) for k, v in value.items() if k not in TIMING and k not in IDENTITY}
    if isinstance(value, list):
        return [strip(v) for v in value]
    return value

a, b = (json.load(open(p)) for p in sys.argv[1:3])
rows_a, rows_b = a.get("rows", []), b.get("rows", [])
if not rows_a:
    print("the threads curve has no rows"); sys.exit(1)
if len(rows_a) != len(rows_b):
    print(f"row counts differ: threads {len(rows_a)}, slurm {len(rows_b)}"); sys.exit(1)
sa, sb = strip(a), strip(b)
if sa != sb:
    for i, (ra, rb) in enumerate(zip(strip(rows_a), strip(rows_b))):
        if ra != rb:
            keys = sorted(k for k in set(ra) | set(rb) if ra.get(k) != rb.get(k))
            print(f"row {i} differs in {keys}: threads {[ra.get(k) for k in keys]} slurm {[rb.get(k) for k in keys]}")
            break
    else:
        keys = sorted(k for k in set(sa) | set(sb) if sa.get(k) != sb.get(k))
        print(f"curves differ outside the rows: {keys}")
    sys.exit(1)
print(f"curves equal: {len(rows_a)} rows, every column but wall_seconds")
EOF

# ---- 4. cancel a running Slurm job ----------------------------------------------------------
"$gelctl" --server "$server" submit --preset quick --seed 3 --name e2e-cancel >"$work/submit-cancel.txt" \
  || fail "gelctl submit (cancel)"
cancel_job=$(head -n 1 "$work/submit-cancel.txt" | tr -d '[:space:]')
slurm_id=""
for _ in $(seq 1 300); do
  line=$(squeue -h -t all -o '%i %j %T' | awk -v n="gel-$cancel_job-0" '$2 == n {print $1, $3}' | tail -n 1)
  if [ "${line#* }" = "RUNNING" ]; then
    slurm_id=${line%% *}
    break
  fi
  sleep 0.1
done
[ -n "$slurm_id" ] || fail "job $cancel_job never showed a RUNNING Slurm job"
"$gelctl" --server "$server" cancel "$cancel_job" >/dev/null || fail "gelctl cancel $cancel_job"
state=""
for _ in $(seq 1 200); do
  state=$("$gelctl" --server "$server" status "$cancel_job" --json | json_field state)
  [ "${state^^}" = "CANCELLED" ] && break
  sleep 0.1
done
[ "${state^^}" = "CANCELLED" ] || fail "job $cancel_job is $state after cancel, not CANCELLED"
slurm_state=""
for _ in $(seq 1 200); do
  slurm_state=$(squeue -h -t all -j "$slurm_id" -o %T 2>/dev/null || true)
  [ "$slurm_state" = "CANCELLED" ] && break
  sleep 0.1
done
[ "$slurm_state" = "CANCELLED" ] || fail "Slurm job $slurm_id is '$slurm_state' after gelctl cancel"
echo "cancel: job $cancel_job CANCELLED; its Slurm job $slurm_id CANCELLED"

# ---- 4b. geld restarts while a Slurm job runs: the job keeps running and is followed again ------
"$gelctl" --server "$server" submit "${ensemble_args[@]}" --seed 4 --name e2e-restart >"$work/submit-restart.txt" \
  || fail "gelctl submit (restart)"
restart_job=$(head -n 1 "$work/submit-restart.txt" | tr -d '[:space:]')
restart_slurm_id=""
for _ in $(seq 1 300); do
  line=$(squeue -h -t all -o '%i %j %T' | awk -v n="gel-$restart_job-0" '$2 == n {print $1, $3}' | tail -n 1)
  if [ "${line#* }" = "RUNNING" ]; then
    restart_slurm_id=${line%% *}
    break
  fi
  sleep 0.1
done
[ -n "$restart_slurm_id" ] || fail "job $restart_job never showed a RUNNING Slurm job"
stop_geld "$slurm_pid"
[ "$(squeue -h -t all -j "$restart_slurm_id" -o %T)" = "RUNNING" ] \
  || fail "Slurm job $restart_slurm_id did not keep running across geld's shutdown"
start_geld slurm --executor slurm --workers 2 --slurm-shared-dir "$shared" --slurm-gelsim "$gelsim" \
  --slurm-poll-interval 0.2 --slurm-max-requeues 2
slurm_pid=$last_geld_pid
state=""
for _ in $(seq 1 1800); do
  state=$("$gelctl" --server "$server" status "$restart_job" --json | json_field state)
  case "${state^^}" in SUCCEEDED | FAILED | CANCELLED) break ;; esac
  sleep 0.2
done
[ "${state^^}" = "SUCCEEDED" ] || fail "job $restart_job is $state after geld's restart, not SUCCEEDED"
submitted=$(grep -c "gel-$restart_job-0" <(squeue -h -t all -o '%j') || true)
[ "$submitted" = "1" ] || fail "job $restart_job was submitted to Slurm $submitted times; expected 1 (followed again)"
echo "restart: geld stopped and restarted while Slurm job $restart_slurm_id ran; job $restart_job SUCCEEDED without resubmission"

# ---- the Slurm job ids are stored with the jobs (member_runs) ----------------------------------
python3 - "$work/data-slurm/geld.sqlite" "$slurm_job" <<'EOF' || fail "Slurm job ids not stored with the job"
import re, sqlite3, sys
db = sqlite3.connect(f"file:{sys.argv[1]}?mode=ro", uri=True)
rows = db.execute("SELECT member, executor, handle FROM member_runs WHERE job_id = ? ORDER BY member",
                  (sys.argv[2],)).fetchall()
assert [r[0] for r in rows] == [0, 1], rows
assert all(r[1] == "slurm" and re.fullmatch(r"\d+:\d+", r[2]) for r in rows), rows
print("stored Slurm handles (job id:requeues):", ", ".join(f"member {m}: {h}" for m, _, h in rows))
EOF

stop_geld "$slurm_pid"

# ---- 5. overhead ----------------------------------------------------------------------------
python3 - "$threads_seconds" "$slurm_seconds" "$threads_small" "$slurm_small" <<'EOF'
import sys
t, s, ts, ss = map(float, sys.argv[1:5])
print(f"OVERHEAD quick preset, 2-seed ensemble (members run one after the other), submit -> SUCCEEDED: "
      f"threads {t:.2f} s, slurm {s:.2f} s, difference {s - t:+.2f} s per job ({(s - t) / 2:+.2f} s per member; "
      f"compute time on a shared machine varies by more than this)")
print(f"OVERHEAD per single-member job with ~2 s of compute (quick, fast fidelity, 2 targets; median of 3): "
      f"threads {ts:.2f} s, slurm {ss:.2f} s, slurm executor overhead {ss - ts:+.2f} s per job")
EOF
echo "PASS: test_slurm_e2e (threads job $threads_job, slurm job $slurm_job, cancelled job $cancel_job)"
