#!/usr/bin/env bash
# Checks deploy/geld.service (and the Slurm drop-in deploy/geld-slurm.conf) with
# `systemd-analyze verify`, which needs no running systemd.
#
#   test_systemd_unit.sh SOURCE_DIR GELD_BINARY
#
# verify insists that ExecStart's binary exists and is executable, and the unit names the
# installed path /usr/local/bin/geld; so the check runs on a temporary copy of the unit whose
# ExecStart names the freshly built geld instead (everything else is verified unchanged). The
# drop-in goes next to the copy (geld.service.d/), where verify loads it, with its
# ReadWritePaths pointed at an existing directory. Unknown keys are only warnings for verify
# (exit code 0), so any output at all fails the test. Exit 77 (skip) without systemd-analyze.
set -euo pipefail

if [ $# -ne 2 ]; then
  echo "usage: $0 SOURCE_DIR GELD_BINARY" >&2
  exit 2
fi
source_dir=$1
geld=$2

if ! command -v systemd-analyze >/dev/null 2>&1; then
  echo "SKIP: systemd-analyze not found (install the systemd package)"
  exit 77
fi
[ -x "$geld" ] || { echo "FAIL: geld binary '$geld' is not executable" >&2; exit 1; }

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

unit="$source_dir/deploy/geld.service"
grep -q '^ExecStart=/usr/local/bin/geld --config /etc/geld/geld.conf$' "$unit" \
  || { echo "FAIL: $unit: ExecStart is not '/usr/local/bin/geld --config /etc/geld/geld.conf'" >&2; exit 1; }

verify() {
  local what=$1 output status=0
  output=$(cd "$work" && systemd-analyze verify "$work/geld.service" 2>&1) || status=$?
  if [ "$status" -ne 0 ] || [ -n "$output" ]; then
    echo "FAIL: systemd-analyze verify ($what) exit $status:" >&2
    echo "$output" >&2
    exit 1
  fi
  echo "ok: systemd-analyze verify ($what)"
}

sed "s#^ExecStart=/usr/local/bin/geld #ExecStart=$geld #" "$unit" >"$work/geld.service"
verify "geld.service"

mkdir -p "$work/geld.service.d" "$work/shared"
sed "s#^ReadWritePaths=.*#ReadWritePaths=$work/shared#" "$source_dir/deploy/geld-slurm.conf" \
  >"$work/geld.service.d/slurm.conf"
verify "geld.service + geld-slurm.conf drop-in"

# The hardening the deploy README promises.
for key in DynamicUser=yes StateDirectory=geld KillSignal=SIGTERM Restart=on-failure \
  NoNewPrivileges=yes ProtectSystem=strict; do
  grep -qx "$key" "$unit" || { echo "FAIL: $unit lacks $key" >&2; exit 1; }
done
timeout=$(sed -n 's/^TimeoutStopSec=\([0-9]*\)$/\1/p' "$unit")
[ -n "$timeout" ] && [ "$timeout" -ge 60 ] \
  || { echo "FAIL: TimeoutStopSec must leave >= 60 s to checkpoint (got '${timeout}')" >&2; exit 1; }
echo "ok: hardening and stop settings present"
