#!/bin/bash
# Run the paper authors' compression code (ryseto/ColloidalGelRheology, a wall version: 491cca3
# (Jan 2013, the paper's era, the default) or ac47e98 (Dec 2013), built OUTSIDE this repository,
# see docs/reference_code.md) on a gel made by the product's gelsim, and convert its output into a
# product-style curve.json (a cached run).
#
#   tools/reference_code/run_reference.sh REF_BUILD_DIR BOND FAMILY SEED
#     REF_BUILD_DIR  folder holding the reference binary ColloidalGelRheology and a file VERSION
#                    (491cca3 or ac47e98; missing: 491cca3)
#     BOND           1 or 2
#     FAMILY         small (150 x 250, 22 flocs of 64 = 1408 particles) or paper (the presets)
#     SEED           the product generator's seed
#   environment: GELSIM (default build-ref/core/gelsim of this checkout), REFRUNS (default
#     /work/refruns), TIMEOUT_S (default 0 = none; a stopped run still converts its rows),
#     EXTRA_ARGS (passed to gel_to_reference.py, e.g. "--max-wait 50").
# Output: $REFRUNS/<family>-bond<b>[-ac47e98]/seed_<s>/{gel.json, run/, curve.json, time.json}
set -euo pipefail
if [ $# -ne 4 ]; then sed -n '2,19p' "$0"; exit 2; fi
REF_BUILD=$(cd "$1" && pwd); BOND=$2; FAMILY=$3; SEED=$4
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
GELSIM=${GELSIM:-$ROOT/build-ref/core/gelsim}
REFRUNS=${REFRUNS:-/work/refruns}
TIMEOUT_S=${TIMEOUT_S:-0}
PY=/usr/bin/python3
BIN=$REF_BUILD/ColloidalGelRheology
[ -x "$BIN" ] || { echo "no $BIN (build it, see docs/reference_code.md)"; exit 2; }
[ -x "$GELSIM" ] || { echo "no gelsim at $GELSIM"; exit 2; }
case "$BOND" in 1|2) ;; *) echo "BOND is 1 or 2"; exit 2;; esac
VERSION=491cca3
[ -f "$REF_BUILD/VERSION" ] && VERSION=$(tr -d ' \n' <"$REF_BUILD/VERSION")
case "$VERSION" in 491cca3) SUFFIX="";; ac47e98) SUFFIX="-ac47e98";; *) echo "unsupported version $VERSION"; exit 2;; esac
OUT=$REFRUNS/$FAMILY-bond$BOND$SUFFIX/seed_$SEED
if [ -f "$OUT/curve.json" ] && grep -q '"complete": true' "$OUT/curve.json"; then
  echo "cached: $OUT/curve.json"; exit 0
fi
mkdir -p "$OUT"
case "$FAMILY" in
  small) nice -n 19 "$GELSIM" generate --lx 150 --ly 250 --n-floc 64 --n-clusters 22 --seed "$SEED" --out "$OUT/gel.json" >"$OUT/generate.txt";;
  paper) nice -n 19 "$GELSIM" generate --preset "paper-bond$BOND" --seed "$SEED" --out "$OUT/gel.json" >"$OUT/generate.txt";;
  *) echo "FAMILY is small or paper"; exit 2;;
esac
rm -rf "$OUT/run"; mkdir -p "$OUT/run"
# shellcheck disable=SC2086
CONF=$($PY "$HERE/gel_to_reference.py" "$OUT/gel.json" "$OUT/run" --bond "$BOND" --seed "$SEED" --code-version "$VERSION" ${EXTRA_ARGS:-})
cd "$OUT/run"
# The code writes data_/log_/conf_/deform_ files into the working directory and parses the box
# size from the D..W..H.._ pattern of the relative configuration path.
START=$(date +%s.%N)
set +e
if [ "$TIMEOUT_S" != "0" ]; then
  /usr/bin/time -f '{"user": %U, "sys": %S, "elapsed": %e, "maxrss_kb": %M}' -o ../time.json \
    timeout "$TIMEOUT_S" nice -n 19 "$BIN" c p.txt "$CONF" 0 >stdout.txt 2>stderr.txt
else
  /usr/bin/time -f '{"user": %U, "sys": %S, "elapsed": %e, "maxrss_kb": %M}' -o ../time.json \
    nice -n 19 "$BIN" c p.txt "$CONF" 0 >stdout.txt 2>stderr.txt
fi
RC=$?
set -e
END=$(date +%s.%N)
WALL=$(echo "$END - $START" | bc)
CPU=$($PY -c "import json,sys; t=json.loads(open('../time.json').read().splitlines()[-1]); print(t['user']+t['sys'])" 2>/dev/null || echo 0)
echo "exit $RC wall ${WALL}s cpu ${CPU}s"
$PY "$HERE/reference_to_curve.py" "$OUT/run" --out "$OUT/curve.json" --wall-seconds "$WALL" --cpu-seconds "$CPU"
# The configuration dumps are large; keep the compact files, compress the rest.
gzip -f conf_*.dat deform_*.dat stderr.txt 2>/dev/null || true
exit $RC
