#!/usr/bin/env bash
# One geld per store, however the second one is pointed at it. A second daemon whose --db named
# the first one's geld.sqlite from another data dir started, recovered the same queue and ran
# the same jobs (one was recorded `succeeded` twice). With geld A serving data dir a/, each of
# these is refused at start, non-zero, with the file and A's pid named:
#   the same data dir; another data dir with --db a/geld.sqlite; the same data dir with another
#   --db; a symlink to a/geld.sqlite; a hard link to it; a relative spelling of its path.
# Then A still runs a job to the end, and once A has stopped, its store is free for another.
#
#   test_store_owner.sh BUILD_DIR
set -euo pipefail
build=$(cd "$1" && pwd)
geld=$build/server/geld
gelctl=$build/client/gelctl
py=/usr/bin/python3
work=$(cd "$(mktemp -d /tmp/geld-owner.XXXXXX)" && pwd -P)  # no symlink in it, as geld names the real file
source "$(dirname "$0")/geld_lib.sh"
trap 'stop_geld; rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
free_port() { $py -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1]); s.close()'; }

# start_geld LOG ARGS...: sets geld_pid and port, waits until it answers.
start_geld() {
  local log=$1
  shift
  port=$(free_port)
  "$geld" --listen "127.0.0.1:$port" --workers 1 "$@" > "$log" 2>&1 &
  geld_pid=$!
  for _ in $(seq 300); do
    "$gelctl" --server "127.0.0.1:$port" list > /dev/null 2>&1 && return 0
    kill -0 "$geld_pid" 2>/dev/null || fail "geld $* did not start: $(tail -3 "$log")"
    sleep 0.05
  done
  fail "geld $* did not answer"
}

cd "$work"
mkdir -p b c d sub
start_geld a.log --data-dir "$work/a"
first=$geld_pid
first_port=$port
store=$work/a/geld.sqlite
ln -s "$store" link.sqlite
ln "$store" hard.sqlite

# refused NAME PATTERN ARGS...: a second geld (on a port of its own, so that a refusal is the
# lock's and not the port's) must exit non-zero within 20 s, its message matching PATTERN.
refused() {
  local name=$1 pattern=$2
  shift 2
  local code=0
  timeout 20 "$geld" --listen "127.0.0.1:$(free_port)" --workers 1 "$@" > "$name.log" 2>&1 || code=$?
  [ "$code" -ne 0 ] && [ "$code" -ne 124 ] || fail "$name: a second geld ($*) exited $code instead of refusing: $(tail -3 "$name.log")"
  grep -qE "$pattern" "$name.log" || fail "$name: the refusal does not match '$pattern': $(tail -3 "$name.log")"
  grep -qF "(pid $first)" "$name.log" || fail "$name: the refusal does not name the holder's pid $first: $(tail -3 "$name.log")"
}
in_use="is in use by another geld"
refused same-data-dir "data dir $work/a $in_use" --data-dir "$work/a"
refused other-data-dir "store $store $in_use" --data-dir "$work/b" --db "$store"
refused same-data-dir-other-db "data dir $work/a $in_use" --data-dir "$work/a" --db "$work/b/other.sqlite"
refused symlink "store link.sqlite \($store\) $in_use" --data-dir "$work/c" --db link.sqlite
refused hard-link "store $work/hard.sqlite $in_use" --data-dir "$work/c" --db "$work/hard.sqlite"
(cd sub && refused relative "store \.\./a/\./geld.sqlite \($store\) $in_use" --data-dir ../d --db ../a/./geld.sqlite)

# A still serves and runs a job to the end.
"$gelctl" --server "127.0.0.1:$first_port" submit --preset quick --fidelity fast --set generator.n_floc=8 \
  --set generator.n_clusters=8 --set generator.lx=30 --set generator.ly=50 --set compression.steps=3 --seed 1 \
  --watch > job.txt || fail "the first geld did not run a job after the refusals: $(tail -3 job.txt)"
job=$(head -n 1 job.txt)
grep -qxF "$job: succeeded" job.txt || fail "the job did not succeed: $(cat job.txt)"
stop_geld

# With A gone the store is free: the daemon refused for another data dir now starts on it and
# finds A's job (the lock was the refusal, not the configuration).
start_geld b.log --data-dir "$work/b" --db "$store"
"$gelctl" --server "127.0.0.1:$port" status "$job" | grep -q succeeded || fail "the store's next owner does not see $job"
stop_geld
echo "store owner: a second geld refused on the same data dir, the same store by path, symlink, hard link and relative path"
