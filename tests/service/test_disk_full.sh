#!/usr/bin/env bash
# A full disk under a running job, with the real geld on a real (size-capped tmpfs) file system:
# the daemon must not die, the job pauses with a message that says why, reads keep working, and
# once space is back the job resumes from its checkpoint and ends with the rows of an
# uninterrupted run. The tmpfs is mounted in a private mount namespace the test makes itself
# (needs root: skipped, exit 77, where unshare cannot do that).
#
#   test_disk_full.sh BUILD_DIR
set -euo pipefail
TEST_NAME=geld-diskfull
MOUNT_NAME=data
source "$(dirname "$0")/mount_ns_lib.sh" "$0" "$@"
fail() { echo "FAIL: $*" >&2; [ -f "$work/geld.log" ] && tail -20 "$work/geld.log" >&2; exit 1; }
port=$($py -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1]); s.close()')
ctl() { "$gelctl" --server "127.0.0.1:$port" "$@"; }

mkdir -p "$work/data"
mount -t tmpfs -o size=4m tmpfs "$work/data" || { echo "SKIP: test_disk_full: cannot mount a tmpfs"; exit 77; }
"$geld" --listen "127.0.0.1:$port" --data-dir "$work/data" --workers 1 --disk-full-retry 0.3 --log-level info \
  > "$work/geld.log" 2>&1 &
geld_pid=$!
for _ in $(seq 300); do ctl list > /dev/null 2>&1 && break; sleep 0.05; done
ctl list > /dev/null || fail "geld did not start"

# Fill the disk, leaving less than one checkpoint and snapshot of the job below.
dd if=/dev/zero of="$work/data/filler" bs=4k 2>/dev/null || true
rm -f "$work/data/filler"
avail=$(df -B1 --output=avail "$work/data" | tail -1)
dd if=/dev/zero of="$work/data/filler" bs=4096 count=$(( (avail - 120 * 1024) / 4096 )) 2>/dev/null \
  || fail "could not make the filler"
JOB=(--preset quick --fidelity fast --set compression.steps=6 --seed 3)
ctl submit "${JOB[@]}" --name diskfull > "$work/submit.txt" || fail "submit on a nearly full disk"
job=$(head -1 "$work/submit.txt")
[[ $job =~ ^job-[0-9]+$ ]] || fail "submit gave no job id: $job"

# The job pauses: geld alive, the job still running with the reason as its message.
paused=0
for _ in $(seq 400); do
  kill -0 "$geld_pid" 2>/dev/null || fail "geld died on a full disk"
  ctl status "$job" --json > "$work/status.json" 2>/dev/null || true
  if grep -q "waiting for disk space" "$work/status.json"; then paused=1; break; fi
  grep -q '"state": *"\(succeeded\|failed\)"' "$work/status.json" && break
  sleep 0.05
done
[ "$paused" -eq 1 ] || fail "the job did not pause for disk space: $(cat "$work/status.json")"
grep -q '"state": *"running"' "$work/status.json" || fail "a paused job is not running: $(cat "$work/status.json")"
sleep 1  # a few retries, all on a full disk
kill -0 "$geld_pid" 2>/dev/null || fail "geld died while retrying"
ctl list > "$work/list.txt" || fail "list failed while the disk is full"
grep -q "$job" "$work/list.txt" || fail "the paused job is not listed"
grep -q "waiting for disk space" "$work/geld.log" || fail "the daemon log does not say why the job waits"

# Space is back: the job finishes, with every row, equal to an uninterrupted run of its seed.
rm -f "$work/data/filler"
state=
for _ in $(seq 600); do
  state=$(ctl status "$job" --json | $py -c 'import json,sys; print(json.load(sys.stdin)["state"])')
  [ "$state" = running ] || [ "$state" = queued ] || break
  sleep 0.1
done
[ "$state" = succeeded ] || fail "after space came back the job is $state"
ctl curve "$job" --json > "$work/paused.json" || fail "curve of the resumed job"
ctl submit "${JOB[@]}" --name uninterrupted --watch > "$work/submit2.txt" || fail "uninterrupted job"
job2=$(head -1 "$work/submit2.txt")
ctl curve "$job2" --json > "$work/whole.json" || fail "curve of the uninterrupted job"
$py - "$work/paused.json" "$work/whole.json" <<'PY' || fail "the resumed job's rows differ from an uninterrupted run"
import json, sys
def rows(path):
    d = json.load(open(path))
    rows = d["rows"] if "rows" in d else d["members"][0]["rows"]
    return [{k: v for k, v in r.items() if k not in ("wall_seconds", "wallSeconds")} for r in rows]
a, b = rows(sys.argv[1]), rows(sys.argv[2])
assert len(a) == 7, f"{len(a)} rows"
assert a == b, "rows differ"
PY
echo "disk full: ok"
