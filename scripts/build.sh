#!/usr/bin/env bash
# Configures and builds the package (and its tests) in _build/ with the system's ROS 1.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B _build -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCATKIN_ENABLE_TESTING=ON > _build.log 2>&1 \
  || { cat _build.log; exit 1; }
cmake --build _build --target all tests -- -j"$(nproc)"
