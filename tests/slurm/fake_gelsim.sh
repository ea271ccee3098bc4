#!/usr/bin/env bash
# Stands in for `gelsim compress` in the Slurm executor's tests, so they exercise Slurm and
# the progress-file protocol without the engine. Same command line:
#   fake_gelsim.sh compress --scene FILE --out DIR --progress-file FILE [--resume]
# The scene file's "mode" picks the behaviour:
#   ok        three rows (one in curve.json's spelling, two in the proto JSON mapping), curve.json
#             copied from DIR/../curve-template.json when present, then done
#   fail      a "failed" line, exit 2
#   crash     a message on stderr, exit 3, no outcome line
#   slow      progress lines every 0.2 s for 10 minutes (to be cancelled or stopped)
#   timeout   without --resume: a checkpoint and one row, then sleeps (TIMEOUT in Slurm);
#             with --resume: rows 2 and 3, then done
#   wait      waits for DIR/go to exist, then behaves as ok
set -euo pipefail
[ "${1:-}" = compress ] || { echo "fake_gelsim: only 'compress'" >&2; exit 2; }
shift
scene="" out="" progress="" resume=0
while [ $# -gt 0 ]; do
  case "$1" in
    --scene) scene=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --progress-file) progress=$2; shift 2 ;;
    --resume) resume=1; shift ;;
    *) echo "fake_gelsim: unknown argument $1" >&2; exit 2 ;;
  esac
done
mode=$(sed -n 's/.*"mode" *: *"\([a-z]*\)".*/\1/p' "$scene")
echo "fake_gelsim: mode=$mode resume=$resume out=$out"

row_curve_json() {  # k phi: curve.json's spelling
  printf '{"type":"row","row":{"k":%d,"phi":%s,"target_phi":%s,"P":%s,"P_top":%s,"P_bot":%s,"contact_number":3.5,"stored_energy":0.1,"dissipated_energy":0.2,"ruptures":{"normal":1,"sliding":2,"rolling":3},"bonds_created":4,"equilibrated":true,"steps":100,"sim_time":1.5,"wall_seconds":0.01}}\n' \
    "$1" "$2" "$2" "$1.5" "$1.25" "$1.75" >>"$progress"
}
row_proto() {  # k phi: proto JSON mapping, flat
  printf '{"type":"row","k":%d,"phi":%s,"targetPhi":%s,"p":%s,"pTop":%s,"pBot":%s,"contactNumber":3.5}\n' \
    "$1" "$2" "$2" "$1.5" "$1.25" "$1.75" >>"$progress"
}
progress_line() {
  printf '{"type":"progress","progress":{"k":%d,"kTotal":3,"phi":0.3,"targetPhi":0.31,"p":0.5,"phase":"compressing"}}\n' "$1" >>"$progress"
}
finish_ok() {
  if [ -f "$out/../curve-template.json" ]; then cp "$out/../curve-template.json" "$out/curve.json"; fi
  echo '{"type":"done"}' >>"$progress"
}

case "$mode" in
  ok)
    progress_line 1
    row_curve_json 1 0.31
    # A line written in two parts: the follower must wait for its newline.
    printf '{"type":"progress","progress":{"k":2,' >>"$progress"
    sleep 0.3
    printf '"kTotal":3,"phi":0.32,"phase":"compressing"}}\n' >>"$progress"
    row_proto 2 0.32
    row_proto 3 0.33
    finish_ok
    ;;
  fail)
    progress_line 1
    echo '{"type":"failed","error":"invalid argument: compression.phi_max: must exceed phi0"}' >>"$progress"
    exit 2
    ;;
  crash)
    progress_line 1
    echo "gelsim: numerical instability: step 12: particle 3 moved 0.7 a in one step" >&2
    exit 3
    ;;
  slow)
    for i in $(seq 1 3000); do progress_line 1; sleep 0.2; done
    ;;
  timeout)
    if [ "$resume" -eq 0 ]; then
      row_curve_json 1 0.31
      echo checkpoint >"$out/checkpoint.bin"
      sleep 600
    else
      [ -f "$out/checkpoint.bin" ] || { echo "fake_gelsim: --resume without checkpoint" >&2; exit 2; }
      row_proto 2 0.32
      row_proto 3 0.33
      finish_ok
    fi
    ;;
  wait)
    while [ ! -e "$out/go" ]; do sleep 0.1; done
    progress_line 1
    row_curve_json 1 0.31
    row_proto 2 0.32
    row_proto 3 0.33
    finish_ok
    ;;
  *)
    echo "fake_gelsim: unknown mode '$mode'" >&2
    exit 2
    ;;
esac
