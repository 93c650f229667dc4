#!/usr/bin/env bash
# The README's first command: installs dependencies, builds drivetap and decodes a bundled capture
# (captures/session-e9: a master polling an ERMAN E-9, a fault appearing and cleared).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
bash scripts/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build build -j "$(nproc 2>/dev/null || echo 2)" >/dev/null
./build/drivetap read captures/session-e9/input.log
