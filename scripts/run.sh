#!/usr/bin/env bash
# Installs what is missing, builds the release program and replays the bundled default scenario
# and pose log headless. Outputs go to out/default (report.json, run.json, frames.csv, mesh.vtu and
# the pictures top.png, oblique.png, section.png), the instructor's page to out/default/html.
# Extra arguments are passed to `scalpelsim replay`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cmake --preset release
cmake --build --preset release --target scalpelsim
./build/release/sim/scalpelsim replay --out out/default --images "$@"
./build/release/sim/scalpelsim report out/default --out out/default/html
