# Read by CTest after doctest's list of test cases (tests/CMakeLists.txt): labels `slow` the test
# cases of the doctest suite "slow", listed by the test program `scalpel_tests_exe`. doctest's own
# ADD_LABELS cannot: it asks for each test case by a name it does not escape, and a comma in the
# name splits it.
if(NOT EXISTS "${scalpel_tests_exe}")
  return()
endif()
execute_process(COMMAND "${scalpel_tests_exe}" --list-test-cases --test-suite=slow OUTPUT_VARIABLE listed
                RESULT_VARIABLE failed)
if(failed)
  return()
endif()
string(REPLACE "\n" ";" listed "${listed}")  # test case names hold no ';' (scripts/test.sh checks)
foreach(name IN LISTS listed)
  if(name AND NOT name MATCHES "^(\\[doctest\\] |=+$)")
    set_tests_properties("${name}" PROPERTIES LABELS slow)
  endif()
endforeach()
