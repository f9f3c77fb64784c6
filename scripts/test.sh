#!/usr/bin/env bash
# Installs what is missing, then runs the stages named (default: all three, as CI does):
#   validate        build with the mesh invariants checked after every mutation (SCALPEL_VALIDATE,
#                   warnings as errors), check formatting, run every test;
#   release-strict  build what users build (Release, -O3) with warnings as errors: GCC warns about
#                   some code only when it inlines as much as -O3 does; the tests ran under validate;
#   debug           build at -O0 with assertions and _GLIBCXX_ASSERTIONS (bounds-checked standard
#                   containers) and run the tests that finish there in a few minutes (below).
set -euo pipefail
cd "$(dirname "$0")/.."
stages=("$@")
[ ${#stages[@]} -gt 0 ] || stages=(validate release-strict debug)
bash scripts/setup.sh

validate() {
  cmake --preset validate
  cmake --build --preset validate
  bash scripts/check-format.sh
  # CTest splits a test name at ';' into entries that match no test case and pass without running.
  if build/validate/tests/scalpel_tests --list-test-cases | grep -n ';'; then
    echo "test.sh: a test case name above holds ';'; CTest would not run it" >&2
    exit 1
  fi
  ctest --preset validate -j "$(nproc)"
}

release-strict() {
  cmake --preset release-strict
  cmake --build --preset release-strict
}

# At -O0 the tissue solve and the cutter run up to a hundred times slower than in the validate build
# (a replay: 5 s there, about 10 minutes here): the debug test preset leaves out the test cases labelled `slow`
# (tests/CMakeLists.txt), those that take more than about 20 s there. The rest, 168 of 221, covers
# every library in about 2 minutes on 2 cores; the validate stage ran all of them.
debug() {
  cmake --preset debug
  cmake --build --preset debug --target scalpel_tests scalpelsim
  ctest --preset debug -j "$(nproc)"
}

for stage in "${stages[@]}"; do
  case "$stage" in
    validate | release-strict | debug) echo "test.sh: $stage" && "$stage" ;;
    *) echo "test.sh: unknown stage '$stage' (validate, release-strict, debug)" >&2 && exit 2 ;;
  esac
done
