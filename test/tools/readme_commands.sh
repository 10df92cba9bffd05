#!/usr/bin/env bash
# The tool commands of README.md and docs/ run as written: every `rosrun landmark_loop_closure ...`
# line of their bash blocks is run from the repository root - `--help` as it is, evaluations with --dry-run
# appended (arguments, config, image lists and ground truth read; nothing evaluated, which would
# take hours). Lines whose data is not here (datasets outside ../shared, placeholder files such
# as my_params.yaml) or that stand for others ("...") are listed as skipped. The demo and test
# scripts have their own tests (tool_demo_script, CI itself).
#   readme_commands.sh SOURCE_DIR
set -euo pipefail
cd "$1"
export PATH="/usr/bin:$PATH"
export ROS_HOSTNAME=localhost ROS_MASTER_URI=http://localhost:11311
set +u
source _build/devel/setup.bash
set -u
[ -f _demo/corridor_2laps.bag ] || { mkdir -p _demo; _build/devel/lib/landmark_loop_closure/make_demo_bag _demo/corridor_2laps.bag 2 > /dev/null; }

# The bash blocks' lines, continuation lines joined, comments dropped.
commands=$(awk '/^```bash/ { inside = 1; next } /^```/ { inside = 0; next }
  inside { sub(/[ \t]+#.*$/, ""); if (sub(/\\[ \t]*$/, "")) { line = line $0; next }
           print line $0; line = "" }' README.md docs/*.md | grep '^rosrun landmark_loop_closure ' || true)
ran=0
failed=0
while IFS= read -r command; do
  [ -n "$command" ] || continue
  read -r -a words <<< "$command"
  reason=""
  if [[ "$command" == *"..."* ]]; then reason="stands for the line above it"; fi
  previous=""
  for word in "${words[@]:3}"; do
    if [ -z "$reason" ] && [[ "$word" == */* ]] && [[ "$word" != -* ]] && [ "$previous" != "--output" ] &&
      [[ "$previous" != *-topic ]] &&
      [ ! -e "$word" ]; then
      reason="$word is not here"
    fi
    previous=$word
  done
  if [ -z "$reason" ] && [ "${words[2]}" = lcd_train ]; then reason="trains for minutes (tool_train_learned_descriptors runs it)"; fi
  if [ -n "$reason" ]; then
    echo "skipped: $command ($reason)"
    continue
  fi
  run=("${words[@]}")
  [[ " ${words[*]} " == *" --help "* ]] || run+=(--dry-run)
  if output=$(timeout 300 "${run[@]}" 2>&1); then
    echo "ok:      $command"
    ran=$((ran + 1))
  else
    echo "FAILED:  $command"
    echo "$output" | tail -n 15
    failed=$((failed + 1))
  fi
done <<< "$commands"
echo "README commands: $ran ran, $failed failed"
[ "$failed" -eq 0 ] && [ "$ran" -ge 5 ]
