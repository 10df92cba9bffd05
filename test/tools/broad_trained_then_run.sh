#!/bin/bash
# The broad autoencoder as a robot uses it: trained first on a run of its own (a generated
# corridor bag; `lcd_train broad --bag`), then loaded by the running node, which finds the second
# lap's loops, every one true (test_node_revisit via rostest node_revisit_broad.test).
set -euo pipefail
make_bag="$1" train="$2" package="$3"
folder="$(mktemp -d)"
trap 'rm -rf "$folder"' EXIT
"$make_bag" "$folder/corridor.bag" 1.3 > /dev/null
"$train" broad --bag "$folder/corridor.bag" --output "$folder/corridor.broad"
rostest --text --pkgdir="$package" --package=landmark_loop_closure \
  "$package/test/ros/node_revisit_broad.test" model:="$folder/corridor.broad"
