#!/usr/bin/env bash
# Configures and builds the package in _build/ with the system's ROS 1.
#   scripts/build.sh            the libraries, nodes and tools
#   scripts/build.sh tests      ...and every test
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B _build -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCATKIN_ENABLE_TESTING=ON > _build.log 2>&1 \
  || { cat _build.log; exit 1; }
targets=(all)
if [ "${1:-}" = tests ]; then targets+=(tests); fi
cmake --build _build --target "${targets[@]}" -- -j"$(nproc)"
