#!/usr/bin/env bash
# The README's main command (called by scripts/main.sh): start geld on a free loopback port with
# its embedded SQLite store in a data directory, submit the `quick` compression with
# `gelctl submit --watch`, print the resulting curve, stop geld with SIGTERM and wait for it.
#
#   GEL_BUILD_DIR   build directory holding server/geld and client/gelctl (default: build)
#   GELD_DATA_DIR   data directory (default: a new /tmp/geld-demo.XXXXXX, kept afterwards)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${GEL_BUILD_DIR:-build}
geld=$build/server/geld
gelctl=$build/client/gelctl
for binary in "$geld" "$gelctl"; do
  [ -x "$binary" ] || { echo "demo: $binary is missing; build first (scripts/setup.sh)" >&2; exit 1; }
done
data=${GELD_DATA_DIR:-$(mktemp -d /tmp/geld-demo.XXXXXX)}
port=$(/usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1]); s.close()')
server=127.0.0.1:$port

"$geld" --listen "$server" --data-dir "$data" --log-file "$data/geld.log" --log-level warn >/dev/null &
geld_pid=$!
stop_geld() {
  if kill -0 "$geld_pid" 2>/dev/null; then
    kill -TERM "$geld_pid"
    wait "$geld_pid" || true
  fi
}
trap stop_geld EXIT

for _ in $(seq 1 100); do
  "$gelctl" --server "$server" list >/dev/null 2>&1 && break
  kill -0 "$geld_pid" 2>/dev/null || { echo "demo: geld did not start; see $data/geld.log" >&2; exit 1; }
  sleep 0.1
done
echo "== geld on $server, data in $data (SQLite: $data/geld.sqlite)"

echo "== gelctl submit --preset quick --seed 1 --watch"
start=$(date +%s.%N)
"$gelctl" --server "$server" submit --preset quick --seed 1 --name demo --label demo=quick --watch | tee "$data/watch.txt"
job=$(head -n 1 "$data/watch.txt")

echo "== gelctl curve $job"
"$gelctl" --server "$server" curve "$job"
"$gelctl" --server "$server" curve "$job" --csv --out "$data/$job.csv"
"$gelctl" --server "$server" curve "$job" --json --out "$data/$job.json"
echo "== curve files: $data/$job.csv, $data/$job.json ($(awk "BEGIN{printf \"%.1f\", $(date +%s.%N) - $start}") s)"

echo "== stopping geld (SIGTERM)"
kill -TERM "$geld_pid"
status=0
wait "$geld_pid" || status=$?
trap - EXIT
echo "== geld exited with status $status"
exit "$status"
