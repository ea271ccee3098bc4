# Sourced by the service tests that mount file systems (a size-capped or read-only tmpfs): runs
# the calling script again inside a private mount namespace it makes itself, so its mounts are
# invisible to the machine and vanish with it; exit 77 (skipped) where that is not allowed.
# Then sets build, geld, gelctl, py and work (a fresh folder named after TEST_NAME), and a
# cleanup that kills $geld_pid, unmounts $work/$MOUNT_NAME and removes $work.
#   TEST_NAME=...; MOUNT_NAME=...; source mount_ns_lib.sh "$0" "$@"
script=$1
shift
if [ -z "${GEL_IN_MOUNT_NS:-}" ]; then
  if ! unshare --mount --propagation private true 2>/dev/null; then
    echo "SKIP: $TEST_NAME: cannot make a private mount namespace here (not root?)"
    exit 77
  fi
  exec env GEL_IN_MOUNT_NS=1 unshare --mount --propagation private bash "$script" "$@"
fi
build=$(cd "$1" && pwd)
geld=$build/server/geld
gelctl=$build/client/gelctl
py=/usr/bin/python3
work=$(mktemp -d "/tmp/$TEST_NAME.XXXXXX")
geld_pid=
cleanup() {
  if [ -n "$geld_pid" ]; then
    kill -KILL "$geld_pid" 2>/dev/null || true
    wait "$geld_pid" 2>/dev/null || true
  fi
  umount "$work/$MOUNT_NAME" 2>/dev/null || true
  rm -rf "$work" || true
}
trap cleanup EXIT
