#!/usr/bin/env bash
# Installs the Debian 12 packages the package needs to build, test and run the demo (those of
# every dependency package.xml names: scripts/debian_packages.sh), and fetches the pretrained
# backbone (scripts/fetch_backbone.sh).
# Idempotent: does nothing when everything is present. Needs root (or sudo) only to install.
set -euo pipefail
cd "$(dirname "$0")/.."

# One list: what package.xml names, as Debian 12 packages (scripts/debian_packages.sh).
mapfile -t PACKAGES < <(scripts/debian_packages.sh)
if [ ${#PACKAGES[@]} -eq 0 ]; then
  echo "install_deps: no packages read from package.xml (scripts/debian_packages.sh)" >&2
  exit 1
fi
# npm fetches the pretrained backbone; a Node.js that brings its own npm is enough.
if command -v npm > /dev/null; then
  kept=()
  for package in "${PACKAGES[@]}"; do
    [ "$package" = nodejs ] || [ "$package" = npm ] || kept+=("$package")
  done
  PACKAGES=("${kept[@]}")
fi

missing=()
for package in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$package")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#PACKAGES[@]} packages present"
  scripts/fetch_backbone.sh
  exit 0
fi

LOG=_install.log
echo "install_deps: installing ${#missing[@]} packages (apt's output goes to $LOG): ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
if ! { $SUDO apt-get update -qq &&
  $SUDO apt-get install -y -qq --no-install-recommends -o DPkg::Lock::Timeout=900 "${missing[@]}"; } \
  > "$LOG" 2>&1; then
  tail -n 30 "$LOG" >&2
  echo "install_deps: apt-get failed; its whole output is in $LOG" >&2
  exit 1
fi
echo "install_deps: installed"
scripts/fetch_backbone.sh
