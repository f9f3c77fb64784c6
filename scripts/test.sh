#!/usr/bin/env bash
# Installs what is missing, builds with the mesh invariants checked after every mutation
# (SCALPEL_VALIDATE, warnings as errors), checks formatting and runs every test.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cmake --preset validate
cmake --build --preset validate
bash scripts/check-format.sh
ctest --preset validate -j "$(nproc)"
