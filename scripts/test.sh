#!/usr/bin/env bash
# Installs what is missing, then runs the stages named (default: all of them, as CI does):
#   validate        build with the mesh invariants checked after every mutation (SCALPEL_VALIDATE,
#                   warnings as errors), check formatting, run every test;
#   release-strict  build what users build (Release, -O3) with warnings as errors: GCC warns about
#                   some code only when it inlines as much as -O3 does; the tests ran under validate;
#   asan            build at -O0 with assertions and _GLIBCXX_ASSERTIONS (bounds-checked standard
#                   containers), AddressSanitizer and UndefinedBehaviorSanitizer, and run the tests
#                   that finish there in a few minutes (below);
#   tsan            build the tests of the threads alone with ThreadSanitizer and run them (below);
#   debug           the asan stage without the sanitizers; not in the default list, as asan checks
#                   all it checks;
#   fuzz            build the libFuzzer harnesses with clang and run each parser's for 25 s, then
#                   every input that once crashed one (scripts/fuzz.sh, docs/fuzzing.md).
set -euo pipefail
cd "$(dirname "$0")/.."
stages=("$@")
[ ${#stages[@]} -gt 0 ] || stages=(validate release-strict asan tsan fuzz)
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
# (a replay: 5 s there, about 10 minutes here): the asan and debug test presets leave out the test
# cases labelled `slow` (tests/CMakeLists.txt), those that take more than about 20 s in the debug
# build. The rest covers every library; the validate stage ran all of them.
# CI runs asan in place of debug: the same build and tests with the sanitizers on top, which cost
# less than a second build would. Any finding fails its test: UBSan does not recover
# (-fno-sanitize-recover), ASan stops at the first error and LeakSanitizer checks at exit.
asan() {
  cmake --preset asan
  cmake --build --preset asan --target scalpel_tests scalpel_alloc_tests scalpelsim
  ctest --preset asan -j "$(nproc)"
}

# ThreadSanitizer on every test would be a third full build of the test suite. The tsan preset
# builds the libraries (-O1) and scalpel_thread_tests alone (SCALPEL_THREAD_TESTS,
# tests/CMakeLists.txt): the tests in which threads share data, namely the SPSC ring and the triple
# buffer, the haptic loop and the recorder, the playback device, the tissue's worker team, the live
# session, and the window with its haptic, simulation and render threads on the mock device under
# Xvfb. The test preset sets LP_NUM_THREADS=0: Mesa's software renderer then draws on the window's
# thread, without threads of its own, whose teardown inside Mesa (not instrumented) TSan reports.
tsan() {
  cmake --preset tsan
  cmake --build --preset tsan --target scalpel_thread_tests
  ctest --preset tsan -j "$(nproc)"
}

debug() {
  cmake --preset debug
  cmake --build --preset debug --target scalpel_tests scalpel_alloc_tests scalpelsim
  ctest --preset debug -j "$(nproc)"
}

fuzz() {
  bash scripts/fuzz.sh 25
}

for stage in "${stages[@]}"; do
  case "$stage" in
    validate | release-strict | asan | tsan | debug | fuzz) echo "test.sh: $stage" && "$stage" ;;
    *) echo "test.sh: unknown stage '$stage' (validate, release-strict, asan, tsan, debug, fuzz)" >&2 && exit 2 ;;
  esac
done
