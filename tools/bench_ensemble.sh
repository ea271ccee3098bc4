#!/usr/bin/env bash
# Ensemble wall time, members one at a time against N at a time, for the three ways of running
# an ensemble: `gelsim compress --seeds --jobs`, geld's thread executor (--workers) and geld's
# Slurm executor (--workers, each member its own Slurm job on a throw-away single-node cluster,
# tests/slurm/slurm_cluster.sh; skipped unless root with Slurm installed: GEL_WITH_SLURM=1
# scripts/setup.sh). A benchmark, not a test: it prints times and ratios and asserts nothing
# beyond every run succeeding. Run it on an otherwise idle machine.
#
#   tools/bench_ensemble.sh [--build DIR] [--seeds 1-4] [--parallel 2] [--fidelity F]
#                           [--steps K] [--no-slurm]
#
# The ensemble is the `quick` preset (its fidelity and number of targets unless given).
#
# Prints one line per measurement and a JSON summary on the last line.
set -euo pipefail

here=$(cd "$(dirname "$0")/.." && pwd)
build="$here/build"
seeds="1-4"
parallel=2
fidelity=""
steps=""
slurm=1
while [ $# -gt 0 ]; do
  case "$1" in
    --build) build=$(realpath "$2"); shift 2 ;;
    --seeds) seeds=$2; shift 2 ;;
    --parallel) parallel=$2; shift 2 ;;
    --fidelity) fidelity=$2; shift 2 ;;
    --steps) steps=$2; shift 2 ;;
    --no-slurm) slurm=0; shift ;;
    -h|--help) sed -n 2,14p "$0"; exit 0 ;;
    *) echo "bench_ensemble: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
gelsim="$build/core/gelsim"
geld="$build/server/geld"
gelctl="$build/client/gelctl"
for bin in "$gelsim" "$geld" "$gelctl"; do
  [ -x "$bin" ] || { echo "bench_ensemble: $bin not built (scripts/setup.sh)" >&2; exit 2; }
done
[[ "$parallel" =~ ^[1-9][0-9]*$ ]] || { echo "bench_ensemble: --parallel must be a positive integer" >&2; exit 2; }

# The same scene for gelsim and gelctl: gelsim takes --steps, gelctl a scene field.
scene_args=(--preset quick)
[ -n "$fidelity" ] && scene_args+=(--fidelity "$fidelity")
gelsim_args=("${scene_args[@]}")
gelctl_args=("${scene_args[@]}")
if [ -n "$steps" ]; then
  [[ "$steps" =~ ^[1-9][0-9]*$ ]] || { echo "bench_ensemble: --steps must be a positive integer" >&2; exit 2; }
  gelsim_args+=(--steps "$steps")
  gelctl_args+=(--set "compression.steps=$steps")
fi

work=$(mktemp -d /tmp/gel-bench-ensemble.XXXXXX)
chmod 0755 "$work"
geld_pids=()
cluster_up=0
cleanup() {
  local pid
  for pid in "${geld_pids[@]}"; do
    kill -0 "$pid" 2>/dev/null && kill -KILL "$pid" 2>/dev/null || true
  done
  [ "$cluster_up" = 1 ] && bash "$here/tests/slurm/slurm_cluster.sh" stop "$work/cluster" >/dev/null 2>&1 || true
  rm -rf "$work"
}
trap cleanup EXIT

fail() { echo "bench_ensemble: $*" >&2; exit 1; }
now() { date +%s.%N; }
seconds_since() { python3 -c 'import sys; print(f"{float(sys.argv[2]) - float(sys.argv[1]):.2f}")' "$1" "$(now)"; }
ratio() { python3 -c 'import sys; print(f"{float(sys.argv[2]) / float(sys.argv[1]):.3f}")' "$1" "$2"; }
free_port() {
  python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1]); s.close()'
}

# gelsim_ensemble JOBS: prints the wall seconds of `gelsim compress --seeds --jobs JOBS`.
gelsim_ensemble() {
  local jobs=$1 t0
  t0=$(now)
  "$gelsim" compress "${gelsim_args[@]}" --seeds "$seeds" --jobs "$jobs" --out "$work/gelsim-j$jobs" \
    >"$work/gelsim-j$jobs.log" 2>&1 || fail "gelsim --jobs $jobs failed: $(tail -n 3 "$work/gelsim-j$jobs.log")"
  seconds_since "$t0"
}

# geld_ensemble NAME WORKERS ARGS...: starts geld (loopback, own data dir), submits the ensemble
# with --watch, prints the wall seconds from submit to SUCCEEDED, stops geld.
geld_ensemble() {
  local name=$1 workers=$2
  shift 2
  local port pid server t0 seconds i
  port=$(free_port)
  server="127.0.0.1:$port"
  "$geld" --listen "$server" --data-dir "$work/data-$name" --gelsim "$gelsim" --workers "$workers" "$@" \
    >"$work/geld-$name.log" 2>&1 &
  pid=$!
  geld_pids+=("$pid")
  for i in $(seq 1 200); do
    "$gelctl" --server "$server" list >/dev/null 2>&1 && break
    kill -0 "$pid" 2>/dev/null || fail "geld ($name) exited at start: $(tail -n 3 "$work/geld-$name.log")"
    [ "$i" -lt 200 ] || fail "geld ($name) did not answer within 20 s"
    sleep 0.1
  done
  t0=$(now)
  "$gelctl" --server "$server" submit "${gelctl_args[@]}" --seeds "$seeds" --name "bench-$name" --watch \
    >"$work/watch-$name.txt" 2>&1 || fail "geld ($name): the job did not succeed: $(tail -n 3 "$work/watch-$name.txt")"
  seconds=$(seconds_since "$t0")
  kill -TERM "$pid"
  wait "$pid" || fail "geld ($name) exited non-zero on SIGTERM"
  echo "$seconds"
}

echo "ensemble: ${gelsim_args[*]} --seeds $seeds; serial against $parallel at a time; $(nproc) cores"
results=()
measure() {  # measure LABEL SERIAL_SECONDS PARALLEL_SECONDS
  local r
  r=$(ratio "$2" "$3")
  printf '%-8s serial %8.2f s   %d at a time %8.2f s   ratio %s\n' "$1" "$2" "$parallel" "$3" "$r"
  results+=("\"$1\": {\"serial_s\": $2, \"parallel_s\": $3, \"ratio\": $r}")
}

s=$(gelsim_ensemble 1); p=$(gelsim_ensemble "$parallel"); measure gelsim "$s" "$p"
s=$(geld_ensemble threads1 1 --executor threads)
p=$(geld_ensemble threads$parallel "$parallel" --executor threads)
measure threads "$s" "$p"

if [ "$slurm" = 1 ]; then
  status=0
  bash "$here/tests/slurm/slurm_cluster.sh" check 2>"$work/slurm-check.txt" || status=$?
  if [ "$status" -eq 0 ]; then
    bash "$here/tests/slurm/slurm_cluster.sh" start "$work/cluster" >"$work/cluster.log" 2>&1 \
      || fail "the Slurm test cluster did not start: $(tail -n 3 "$work/cluster.log")"
    cluster_up=1
    # shellcheck disable=SC1091
    . "$work/cluster/env.sh"
    # Each geld gets its own shared folder: both number their first job 1, and a second geld
    # on the first one's folder would find that job's members already finished there.
    slurm_args=(--executor slurm --slurm-gelsim "$gelsim" --slurm-poll-interval 0.2)
    mkdir -p "$work/shared-slurm1" "$work/shared-slurm$parallel"
    s=$(geld_ensemble slurm1 1 "${slurm_args[@]}" --slurm-shared-dir "$work/shared-slurm1")
    p=$(geld_ensemble slurm$parallel "$parallel" "${slurm_args[@]}" --slurm-shared-dir "$work/shared-slurm$parallel")
    measure slurm "$s" "$p"
  else
    echo "slurm    skipped: $(tail -n 1 "$work/slurm-check.txt")"
  fi
fi

joined=$(IFS=,; echo "${results[*]}")
echo "{\"seeds\": \"$seeds\", \"parallel\": $parallel, \"cores\": $(nproc), $joined}"
