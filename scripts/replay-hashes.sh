#!/usr/bin/env bash
# Rewrites tests/data/replay_hashes.txt, the sha256 of the bundled replays' outputs that the tests
# cli_replay_*_matches_stored_hashes check, from the validate build (CI's; the release build gives
# the same outputs) or the scalpelsim given. Run it in the commit that changes what a replay
# produces, and commit the file with it.
set -euo pipefail
cd "$(dirname "$0")/.."
program=${1:-build/validate/sim/scalpelsim}
if [ ! -x "$program" ]; then
  echo "replay-hashes: no $program; build it first (cmake --preset validate && cmake --build --preset validate)" >&2
  exit 1
fi
cmake -DSCALPELSIM="$program" -DOUT=build/replay-hashes -DUPDATE=ON -P tests/cli/replay_hashes.cmake
git --no-pager diff --stat -- tests/data/replay_hashes.txt
