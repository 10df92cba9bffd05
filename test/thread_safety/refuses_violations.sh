#!/usr/bin/env bash
# guarded_counter.cpp compiles under clang's thread-safety analysis as written, and fails to, with
# a thread-safety error, for each violation it can be built with: the annotations are checked,
# not decoration.
#   test/thread_safety/refuses_violations.sh <the package's include directory>
set -uo pipefail
include="$1"
source_file="$(dirname "$0")/guarded_counter.cpp"
compile() {
  clang++ -std=c++17 -fsyntax-only -Wthread-safety -Werror=thread-safety -I"$include" "$@" \
    "$source_file" 2>&1
}
if ! output="$(compile)"; then
  echo "FAIL: the correctly locked code does not compile:"; echo "$output"; exit 1
fi
echo "ok: compiles as written"
failed=0
for violation in VIOLATION_UNLOCKED_READ VIOLATION_REQUIRES_NOT_HELD VIOLATION_READ_AFTER_UNLOCK \
  VIOLATION_READ_ONLY_WAITS VIOLATION_UNASSERTED_CALLBACK; do
  if output="$(compile -D"$violation")"; then
    echo "FAIL: $violation compiles"; failed=1
  elif ! grep -q "Werror,-Wthread-safety" <<< "$output"; then
    echo "FAIL: $violation fails for another reason:"; echo "$output"; failed=1
  else
    echo "ok: $violation refused: $(grep -m1 "error:" <<< "$output" | sed 's/.*error: //')"
  fi
done
exit "$failed"
