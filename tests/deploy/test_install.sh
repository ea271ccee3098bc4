#!/usr/bin/env bash
# `cmake --install` into a temporary prefix, then the README's quickstart lines exactly as the
# README writes them, with HOME pointing at a temporary folder so that ~/.local is the prefix.
# Checks that the installed programs run from the prefix alone and that each quickstart step
# leaves what the README says it leaves.
set -euo pipefail
SOURCE="$1"
BUILD="$2"
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

export HOME="$WORK/home"
mkdir -p "$HOME"
cmake --install "$BUILD" --prefix "$HOME/.local" > "$WORK/install.log" || fail "cmake --install: $(tail -3 "$WORK/install.log")"
for program in gelsim geld gelctl; do
  [ -x "$HOME/.local/bin/$program" ] || fail "$program not installed in bin/"
  "$HOME/.local/bin/$program" --version | grep -Eq "^[0-9]+\.[0-9]+\.[0-9]+ git [0-9a-f]{7,}|unknown" \
    || fail "$program --version: $("$HOME/.local/bin/$program" --version)"
done
[ -f "$HOME/.local/share/doc/gelsim/docs/model.md" ] || fail "docs/model.md not installed"
# The Python package, from the prefix alone (Debian's interpreter finds ~/.local's site-packages).
(cd "$WORK" && env -i HOME="$HOME" PATH=/usr/bin:/bin /usr/bin/python3 -c \
  "import gel, os; assert gel.__file__.startswith(os.environ['HOME']), gel.__file__; from gel.v1 import service_pb2; print(gel.connect)") \
  > "$WORK/python.log" 2>&1 || fail "import gel from the prefix: $(tail -3 "$WORK/python.log")"

# The quickstart block of the README, run line by line in a fresh folder by a fresh shell whose
# PATH does not contain the build tree.
sed -n '/<!-- quickstart:begin/,/<!-- quickstart:end/p' "$SOURCE/README.md" | grep '^    ' | sed 's/^    //' > "$WORK/quickstart.sh"
[ "$(wc -l < "$WORK/quickstart.sh")" -ge 5 ] || fail "no quickstart block found in README.md"
mkdir -p "$WORK/user"
# The sanitizers' settings pass through (a sanitized build is tested with them).
(cd "$WORK/user" && env -i HOME="$HOME" PATH=/usr/bin:/bin ${ASAN_OPTIONS:+ASAN_OPTIONS="$ASAN_OPTIONS"} \
   ${LSAN_OPTIONS:+LSAN_OPTIONS="$LSAN_OPTIONS"} ${UBSAN_OPTIONS:+UBSAN_OPTIONS="$UBSAN_OPTIONS"} \
   bash -euo pipefail "$WORK/quickstart.sh" > "$WORK/quickstart.log" 2>&1) \
  || fail "the README quickstart failed: $(tail -5 "$WORK/quickstart.log")"
for file in gel.json run/curve.csv run/plots/pressure.png run/rows.gsd; do
  [ -s "$WORK/user/$file" ] || fail "the quickstart left no $file"
done
grep -q "git" <(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['program_version'])" "$WORK/user/run/curve.json") \
  || fail "curve.json does not record the git commit"
echo "install: programs, docs and the README quickstart work from the prefix"
