#!/usr/bin/env bash
# The archived paper-size study (docs/reproduction/paper-study) is complete and its committed
# analysis is what this gelsim computes from it: a copy of the archive given to the study command
# runs no member (every one has finished: curve.json plus structure.json), and --analyse-only
# gives study_analysis.json equal to the committed one (timings aside). This is what keeps
# docs/reproduction.md reproducible from the repository alone as the analysis code changes.
set -euo pipefail
GELSIM=${1:?usage: test_archived_paper_study.sh GELSIM}
ARCHIVE=${2:?usage: test_archived_paper_study.sh GELSIM ARCHIVE}
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

# Every member the study lists is archived (else the command below would start a paper-size run).
/usr/bin/python3 - "$ARCHIVE" <<'PY' || fail "the archive lacks members"
import json, os, sys
archive = sys.argv[1]
missing = [f"{e['name']}/seed_{s}/{name}" for e in json.load(open(os.path.join(archive, "study.json")))["ensembles"]
           for s in e["seeds"] for name in ("curve.json", "structure.json")
           if not os.path.exists(os.path.join(archive, e["name"], f"seed_{s}", name))]
if missing:
    sys.exit("missing: " + ", ".join(missing))
PY
cp -r "$ARCHIVE" "$WORK/study"
rm -f "$WORK/study/study_analysis.json"
# The run command itself: with every member finished it must run nothing and only analyse.
"$GELSIM" study --out "$WORK/study" > "$WORK/out" 2> "$WORK/log" || fail "study exited $?: $(tail -3 "$WORK/log")"
if grep -q "done in\|k 0 " "$WORK/log"; then fail "a member ran: $(grep -m1 'done in\|k 0 ' "$WORK/log")"; fi
[ -f "$WORK/study/study_analysis.json" ] || fail "no analysis written"
/usr/bin/python3 - "$ARCHIVE/study_analysis.json" "$WORK/study/study_analysis.json" <<'PY' || fail "the analysis differs from the committed one"
import json, sys
committed, fresh = (json.load(open(p)) for p in sys.argv[1:3])
def strip(value):
    if isinstance(value, dict):
        return {k: strip(v) for k, v in value.items() if not k.endswith("seconds")}
    if isinstance(value, list):
        return [strip(v) for v in value]
    return value
assert [e["name"] for e in fresh["ensembles"]] == ["bond1", "bond2"], [e["name"] for e in fresh["ensembles"]]
for ensemble in fresh["ensembles"]:
    assert ensemble["members"] == 10 and ensemble["seeds"] == list(range(1, 11)), (ensemble["name"], ensemble["seeds"])
if strip(committed) != strip(fresh):
    sys.exit("analysis of the archive is not the committed study_analysis.json")
PY
# The summary it ends with gives the analysis's headline numbers, as the analysis has them.
/usr/bin/python3 - "$WORK/study/study_analysis.json" "$WORK/out" <<'PY' || fail "the printed summary"
import json, sys
analysis, printed = json.load(open(sys.argv[1])), open(sys.argv[2]).read().splitlines()
estimate = lambda e: "%.3g [%.3g, %.3g]" % (e["value"], e["lo"], e["hi"])
assert printed[0] == "members: 20 of 20 finished (0 run now, 20 already done)", printed[0]
for e in analysis["ensembles"]:
    fit = e["power_law"]["all"]
    for line in (f"{e['name']}: 10 seeds (95 % bootstrap intervals over seeds)",
                 "  lambda (P_y ~ phi^lambda, phi %.3g-%.3g): %s" % (fit["phi_min"], fit["phi_max"], estimate(fit["exponent"])),
                 "  gel point: phi_g " + estimate(e["gel_point"]["phi_g"])):
        assert line in printed, (line, printed)
PY
echo "archived paper study: complete, analysis reproduced"
