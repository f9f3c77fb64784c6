# Installs the build into WORK/prefix, moves the prefix to WORK/moved, and replays the bundled
# scenario from an unrelated working folder: the installed program must find the scenario, its
# mesh and log in WORK/moved/share/scalpelsim, not in the source tree.
#   -DBUILD_DIR=<build folder>  -DWORK=<scratch folder>
file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}/cwd")
execute_process(COMMAND ${CMAKE_COMMAND} --install "${BUILD_DIR}" --prefix "${WORK}/prefix"
                RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT code EQUAL 0)
  message(FATAL_ERROR "install failed (${code}):\n${out}${err}")
endif()
file(RENAME "${WORK}/prefix" "${WORK}/moved")
execute_process(COMMAND "${WORK}/moved/bin/scalpelsim" replay --no-progress --out "${WORK}/cwd/out"
                WORKING_DIRECTORY "${WORK}/cwd"
                RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT code EQUAL 0)
  message(FATAL_ERROR "the installed program failed (${code}):\n${out}${err}")
endif()
if(NOT out MATCHES "on ${WORK}/moved/share/scalpelsim/config/scenarios/skin_incision.yaml")
  message(FATAL_ERROR "the installed program did not replay its installed scenario:\n${out}${err}")
endif()
if(NOT EXISTS "${WORK}/cwd/out/report.json")
  message(FATAL_ERROR "no report.json:\n${out}${err}")
endif()
execute_process(COMMAND "${WORK}/moved/bin/scalpelsim" states RESULT_VARIABLE code OUTPUT_QUIET ERROR_QUIET)
if(NOT code EQUAL 0)
  message(FATAL_ERROR "the installed program's `states` failed (${code})")
endif()
message(STATUS "installed and moved: ${out}")
