# Sourced by the service tests that start geld themselves: stop_geld ends the daemon whose pid is
# in $geld_pid (SIGTERM, then waits for it), if any; the caller's EXIT trap calls it.
geld_pid=
stop_geld() {
  if [ -n "$geld_pid" ]; then
    kill -TERM "$geld_pid" 2>/dev/null || true
    wait "$geld_pid" 2>/dev/null || true
    geld_pid=
  fi
}
