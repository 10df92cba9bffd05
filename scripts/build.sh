#!/usr/bin/env bash
# Configures and builds the package in _build/ with the system's ROS 1. The compiler's output goes
# to _build.log; the console gets the phase, progress every 10 % and any warning or error.
#   scripts/build.sh            the libraries, nodes and tools
#   scripts/build.sh tests      ...and every test
set -euo pipefail
cd "$(dirname "$0")/.."
LOG=_build.log
echo "build: configuring (output in $LOG)"
cmake -S . -B _build -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCATKIN_ENABLE_TESTING=ON > "$LOG" 2>&1 \
  || { tail -n 40 "$LOG"; echo "build: configuring failed; see $LOG" >&2; exit 1; }
targets=(all)
if [ "${1:-}" = tests ]; then targets+=(tests); fi
echo "build: compiling ${targets[*]} on $(nproc) cores"
if ! cmake --build _build --target "${targets[@]}" -- -j"$(nproc)" 2>&1 | tee -a "$LOG" |
  awk '/^\[ *[0-9]+%\]/ { match($0, /[0-9]+/); p = substr($0, RSTART, RLENGTH) - 0;
         if (p >= next_step) { printf "build: %d%%\n", p; fflush(); next_step = p - p % 10 + 10 } }
       /warning:|error:/ { print; fflush() }'; then
  echo "build: failed; the compiler's whole output is in $LOG" >&2
  exit 1
fi
echo "build: done ($(grep -c 'warning:' "$LOG" || true) compiler warnings)"
