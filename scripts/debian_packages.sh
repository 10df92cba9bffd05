#!/usr/bin/env bash
# The Debian 12 packages of the dependencies package.xml names, one list: each name's packages
# from scripts/debian_packages.txt (what rosdep's tables would say, for the names Debian's ROS
# has no rosdep data for).
#   scripts/debian_packages.sh          print them, one a line
#   scripts/debian_packages.sh --check  fail when a name has no line there or a line no name
set -euo pipefail
cd "$(dirname "$0")/.."
names() {
  grep -oE '<(buildtool_|build_|exec_|test_)?depend>[^<]+</' package.xml | sed -E 's/^<[a-z_]+>//; s/<\/$//' \
    | sort -u
}
mapped() { grep -vE '^\s*(#|$)' scripts/debian_packages.txt | cut -d: -f1 | sort -u; }
case "${1:-}" in
  --check)
    status=0
    for name in $(comm -23 <(names) <(mapped)); do
      echo "debian_packages: package.xml names $name, scripts/debian_packages.txt has no line for it" >&2
      status=1
    done
    for name in $(comm -13 <(names) <(mapped)); do
      echo "debian_packages: scripts/debian_packages.txt maps $name, which package.xml does not name" >&2
      status=1
    done
    [ "$status" = 0 ] && echo "debian_packages: the $(names | wc -l) dependencies of package.xml each have their Debian packages"
    exit "$status"
    ;;
  "")
    for name in $(names); do
      grep -E "^$name:" scripts/debian_packages.txt | cut -d: -f2- | tr ' ' '\n' | sed '/^$/d'
    done | sort -u
    ;;
  *) echo "usage: scripts/debian_packages.sh [--check]" >&2; exit 2 ;;
esac
