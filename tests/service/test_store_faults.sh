#!/usr/bin/env bash
# geld refuses to start on a data dir it cannot use, says why, and changes nothing there:
#  1. a read-only file system (a tmpfs remounted read-only, in a private mount namespace the
#     test makes itself; needs root, else skipped with exit 77);
#  2. a store with damaged pages (a real store made by geld, then a b-tree page overwritten):
#     refused at start with the damage named and what to do, the file left byte for byte;
#  3. a store whose index no longer matches its table (one key of the job-id index rewritten,
#     the b-tree itself sound): quick_check passed it and geld wrote on through the index.
# Then the same store, repaired by moving it away, starts a fresh daemon that serves.
#
#   test_store_faults.sh BUILD_DIR
set -euo pipefail
TEST_NAME=geld-storefaults
MOUNT_NAME=ro
source "$(dirname "$0")/mount_ns_lib.sh" "$0" "$@"
fail() { echo "FAIL: $*" >&2; exit 1; }
port=$($py -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1]); s.close()')

# Starts geld on $1 and expects it to exit non-zero within 20 s; its log goes to $2.
expect_refusal() {
  set +e
  timeout 20 "$geld" --listen "127.0.0.1:$port" --data-dir "$1" --workers 1 > "$2" 2>&1
  local code=$?
  set -e
  [ "$code" -ne 0 ] && [ "$code" -ne 124 ] || fail "geld on $1 exited $code instead of refusing: $(tail -3 "$2")"
}

# 1. Read-only: a store made while writable, then the file system remounted read-only.
mkdir -p "$work/ro"
mount -t tmpfs -o size=4m tmpfs "$work/ro" || { echo "SKIP: test_store_faults: cannot mount a tmpfs"; exit 77; }
"$geld" --listen "127.0.0.1:$port" --data-dir "$work/ro" --workers 1 > "$work/first.log" 2>&1 &
geld_pid=$!
for _ in $(seq 300); do "$gelctl" --server "127.0.0.1:$port" list > /dev/null 2>&1 && break; sleep 0.05; done
kill -TERM "$geld_pid"; wait "$geld_pid" || true; geld_pid=
mount -o remount,ro "$work/ro"
expect_refusal "$work/ro" "$work/ro.log"
grep -q "Read-only file system" "$work/ro.log" || fail "the read-only refusal does not say so: $(tail -2 "$work/ro.log")"

# 2. Damaged pages: the second page's b-tree header overwritten.
mkdir -p "$work/damaged"
"$geld" --listen "127.0.0.1:$port" --data-dir "$work/damaged" --workers 1 > "$work/second.log" 2>&1 &
geld_pid=$!
for _ in $(seq 300); do "$gelctl" --server "127.0.0.1:$port" list > /dev/null 2>&1 && break; sleep 0.05; done
kill -TERM "$geld_pid"; wait "$geld_pid" || true; geld_pid=
store="$work/damaged/geld.sqlite"
$py - "$store" <<'PY'
import sys
with open(sys.argv[1], "r+b") as f:
    f.seek(4096)  # page 2 (4 KiB pages): its b-tree page header
    f.write(b"\x0d" + b"\xff" * 63)
PY
before=$(sha256sum "$store" | cut -d' ' -f1)
expect_refusal "$work/damaged" "$work/damaged.log"
grep -q "is damaged" "$work/damaged.log" || fail "the damage is not named: $(tail -2 "$work/damaged.log")"
grep -q "recover" "$work/damaged.log" || fail "the refusal does not say what to do: $(tail -2 "$work/damaged.log")"
[ "$(sha256sum "$store" | cut -d' ' -f1)" = "$before" ] || fail "the refused start changed the damaged store"

# 3. A damaged index: jobs submitted, then one job id in the leaf page of jobs' UNIQUE(id) index
# rewritten so that the index is out of order and misses rows. Every page stays well formed.
mkdir -p "$work/index"
"$geld" --listen "127.0.0.1:$port" --data-dir "$work/index" --workers 1 > "$work/index-first.log" 2>&1 &
geld_pid=$!
for _ in $(seq 300); do "$gelctl" --server "127.0.0.1:$port" list > /dev/null 2>&1 && break; sleep 0.05; done
for seed in 1 2 3 4 5 6; do
  "$gelctl" --server "127.0.0.1:$port" submit --preset quick --fidelity fast --set compression.steps=1 --seed "$seed"     > /dev/null || fail "submit to the store whose index gets damaged"
done
kill -TERM "$geld_pid"; wait "$geld_pid" || true; geld_pid=
index_store="$work/index/geld.sqlite"
$py - "$index_store" <<'PY' || fail "cannot damage the index of $index_store"
import sqlite3, sys
path = sys.argv[1]
db = sqlite3.connect(path)
(page_size,) = db.execute("PRAGMA page_size").fetchone()
(root,) = db.execute("SELECT rootpage FROM sqlite_master WHERE type = 'index' AND tbl_name = 'jobs'"
                     " AND sql IS NULL").fetchone()  # the UNIQUE(id) index SQLite made itself
ids = [row[0] for row in db.execute("SELECT id FROM jobs ORDER BY id")]
assert db.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
db.close()
with open(path, "r+b") as f:
    f.seek((root - 1) * page_size)
    page = bytearray(f.read(page_size))
    assert page[0] == 0x0A, "the index's root is not a leaf page"  # one page holds a few ids
    key = ids[2].encode()
    at = page.find(key)
    assert at > 0 and len(ids) >= 6, (key, at)
    page[at + len(key) - 1:at + len(key)] = b"~"  # sorts after every id: the index is out of order
    f.seek((root - 1) * page_size)
    f.write(page)
db = sqlite3.connect(path)
assert db.execute("PRAGMA quick_check").fetchone()[0] == "ok", "quick_check sees the damage: not the case tested"
assert db.execute("PRAGMA integrity_check").fetchone()[0] != "ok"
db.close()
PY
before=$(sha256sum "$index_store" | cut -d' ' -f1)
expect_refusal "$work/index" "$work/index.log"
grep -q "is damaged (.*index" "$work/index.log" || fail "the index damage is not named: $(tail -2 "$work/index.log")"
grep -q "recover" "$work/index.log" || fail "the index refusal does not say what to do: $(tail -2 "$work/index.log")"
[ "$(sha256sum "$index_store" | cut -d' ' -f1)" = "$before" ] || fail "the refused start changed the store with a damaged index"

# The damaged file moved away: a fresh store starts and serves.
mv "$store" "$store.damaged"
rm -f "$store-wal" "$store-shm"
"$geld" --listen "127.0.0.1:$port" --data-dir "$work/damaged" --workers 1 > "$work/third.log" 2>&1 &
geld_pid=$!
for _ in $(seq 300); do "$gelctl" --server "127.0.0.1:$port" list > /dev/null 2>&1 && break; sleep 0.05; done
"$gelctl" --server "127.0.0.1:$port" list > /dev/null || fail "geld did not start on a fresh store"
echo "store faults: read-only, damaged and damaged-index stores refused at start, nothing changed"
