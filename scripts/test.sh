#!/usr/bin/env bash
# Installs what is missing, builds with the mesh invariants checked after every mutation
# (SCALPEL_VALIDATE, warnings as errors), checks formatting and runs every test.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cmake --preset validate
cmake --build --preset validate
bash scripts/check-format.sh
# CTest splits a test name at ';' into entries that match no test case and pass without running.
if build/validate/tests/scalpel_tests --list-test-cases | grep -n ';'; then
  echo "test.sh: a test case name above holds ';'; CTest would not run it" >&2
  exit 1
fi
ctest --preset validate -j "$(nproc)"
