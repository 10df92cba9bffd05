#!/usr/bin/env bash
# The README's demo as a user runs it (scripts/demo.sh, without its install and build steps):
# it exits 0, prints one line per loop, no loop is false, nothing from roslaunch or the detector
# reaches the console (no "REQUIRED process has died" banner), and the summary is the last thing
# printed.
#   demo_script.sh SOURCE_DIR
set -euo pipefail
cd "$1"
export PATH="/usr/bin:$PATH"
out=$(mktemp)
trap 'rm -f "$out"' EXIT
if ! timeout 600 scripts/demo.sh --no-setup --rate 4 > "$out" 2>&1; then
  cat "$out"
  echo "FAIL: scripts/demo.sh exited with an error" >&2
  exit 1
fi
fail() { cat "$out"; echo "FAIL: $*" >&2; exit 1; }
loops=$(grep -c '^loop keyframe' "$out" || true)
[ "$loops" -gt 100 ] || fail "only $loops loop lines"
grep -q '^loop keyframe.* FALSE' "$out" && fail "a false loop was published"
grep -qi 'REQUIRED process' "$out" && fail "roslaunch's REQUIRED banner reached the console"
grep -qE '^\[ *(INFO|WARN|ERROR)' "$out" && fail "the detector's log reached the console"
summary_line=$(grep -n '^==== demo summary ====' "$out" | cut -d: -f1)
[ -n "$summary_line" ] || fail "no summary"
tail -n +"$summary_line" "$out" | grep -vE '^(==== demo summary|keyframes:|revisited|loops published|precision:|recall|verified:|by appearance:|metric pose error:|trajectory RMSE:|pose graph loops:|$)' \
  && fail "something was printed after the summary"
published=$(sed -n 's/^loops published: *\([0-9]*\).*/\1/p' "$out")
[ "$published" = "$loops" ] || fail "$loops loop lines but $published loops in the summary"
echo "demo: $loops loops, one line each, summary last"
