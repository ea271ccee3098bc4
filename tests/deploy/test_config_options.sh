#!/usr/bin/env bash
# Keeps deploy/ in step with geld's flags:
#  1. every key of deploy/geld.conf.example, commented out or not, is a geld flag (--key in
#     `geld --help`), and so is every flag the Dockerfile's CMD and the systemd unit pass;
#  2. geld actually starts from a copy of the example file (data-dir and listen pointed at a
#     temporary directory and a free loopback port), answers `gelctl list`, and exits 0 on
#     SIGTERM.
#
#   test_config_options.sh SOURCE_DIR GELD_BINARY GELCTL_BINARY
set -euo pipefail

if [ $# -ne 3 ]; then
  echo "usage: $0 SOURCE_DIR GELD_BINARY GELCTL_BINARY" >&2
  exit 2
fi
source_dir=$1
geld=$2
gelctl=$3
example="$source_dir/deploy/geld.conf.example"

help=$("$geld" --help 2>&1)
fail=0
keys=$(sed -n 's/^#\{0,1\} *\([a-z][a-z0-9-]*\) *= .*/\1/p' "$example" | sort -u)
[ -n "$keys" ] || { echo "FAIL: no keys found in $example" >&2; exit 1; }
for key in $keys; do
  if ! grep -Eq -- "--$key([^a-z0-9-]|$)" <<<"$help"; then
    echo "FAIL: $example: '$key' is not a geld flag (geld --help has no --$key)" >&2
    fail=1
  fi
done
flags=$( (sed -n 's/^CMD \[\(.*\)\]$/\1/p' "$source_dir/deploy/Dockerfile" | tr ',' '\n' | tr -d ' "';
          sed -n 's/^ExecStart=[^ ]* \(.*\)$/\1/p' "$source_dir/deploy/geld.service" | tr ' ' '\n') \
        | grep -- '^--' | sort -u)
for flag in $flags; do
  if ! grep -Eq -- "$flag([^a-z0-9-]|$)" <<<"$help"; then
    echo "FAIL: deploy/ passes $flag, which geld --help does not list" >&2
    fail=1
  fi
done
[ "$fail" -eq 0 ] || exit 1
echo "ok: $(wc -w <<<"$keys") example keys and $(wc -w <<<"$flags") deploy flags are geld flags"

work=$(mktemp -d)
geld_pid=""
cleanup() {
  if [ -n "$geld_pid" ] && kill -0 "$geld_pid" 2>/dev/null; then kill -KILL "$geld_pid" 2>/dev/null || true; fi
  rm -rf "$work"
}
trap cleanup EXIT
port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1]); s.close()')
sed -e "s#^listen = .*#listen = \"127.0.0.1:$port\"#" -e "s#^data-dir = .*#data-dir = \"$work/data\"#" \
  "$example" >"$work/geld.conf"
"$geld" --config "$work/geld.conf" >"$work/geld.log" 2>&1 &
geld_pid=$!
ok=0
for _ in $(seq 1 100); do
  if "$gelctl" --server "127.0.0.1:$port" list >/dev/null 2>&1; then ok=1; break; fi
  kill -0 "$geld_pid" 2>/dev/null || break
  sleep 0.1
done
if [ "$ok" -ne 1 ]; then
  echo "FAIL: geld --config (example) did not answer gelctl list; its log:" >&2
  cat "$work/geld.log" >&2
  exit 1
fi
kill -TERM "$geld_pid"
status=0
wait "$geld_pid" || status=$?
geld_pid=""
if [ "$status" -ne 0 ]; then
  echo "FAIL: geld exited $status on SIGTERM; its log:" >&2
  cat "$work/geld.log" >&2
  exit 1
fi
echo "ok: geld starts from the example configuration and stops cleanly on SIGTERM"
