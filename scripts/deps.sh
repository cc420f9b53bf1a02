#!/usr/bin/env bash
# Installs the Debian 12 packages trompo needs, if any is missing (as root, via apt-get).
# Usage: scripts/deps.sh [extra packages...]
set -euo pipefail
need=(cmake g++ make libeigen3-dev catch2 libbenchmark-dev libboost-dev "$@")
missing=()
for p in "${need[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "deps: installing ${missing[*]}"
  if [ "$(id -u)" -ne 0 ]; then
    echo "deps: missing packages and not root; run: apt-get install ${missing[*]}" >&2
    exit 1
  fi
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
