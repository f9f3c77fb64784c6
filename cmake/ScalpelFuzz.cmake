# SCALPEL_FUZZ (the `fuzz` preset): the libFuzzer harnesses of fuzz/ (docs/fuzzing.md) instead of
# the program. Every object is instrumented for libFuzzer's coverage, AddressSanitizer and
# UndefinedBehaviorSanitizer; undefined behaviour aborts, so the fuzzer keeps the input that made
# it. Only the parsers are built (the mesh library and, in fuzz/, the sources of the other parsers):
# the cutter, the tissue and the program would double the build for code no harness reaches.
if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
  message(FATAL_ERROR "SCALPEL_FUZZ needs clang (libFuzzer): cmake --preset fuzz")
endif()
add_compile_options(-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined
                    -fno-omit-frame-pointer)
add_link_options(-fsanitize=address,undefined)
foreach(dir base mesh fuzz)
  add_subdirectory(${dir})
endforeach()
