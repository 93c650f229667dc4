#!/usr/bin/env bash
# Installs drivetap's build and test dependencies from Debian (bookworm), as root; packages given
# as arguments are installed too (scripts/test.sh and scripts/fuzz.sh add clang and the tools of
# the sanitizer and fuzz builds).
set -euo pipefail
packages=(build-essential cmake ninja-build pkg-config libfmt-dev libcli11-dev libgtest-dev libgmock-dev
          libpcap-dev libtomlplusplus-dev libzip-dev libbenchmark-dev tshark sigrok-cli time python3
          libjs-chart.js chromium python3-pymodbus
          "$@")
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ "${#missing[@]}" -gt 0 ]; then
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
