# Replays the bundled default scenario and log twice and requires identical outputs: mesh.vtu byte
# for byte, report.json without its wall-clock timings.
#   -DSCALPELSIM=<program>  -DOUT=<folder>  [-DLOG=<pose log>, default: the scenario's]
#   [-DSCENARIO=<scenario>, default: config/scenarios/skin_incision.yaml]
#   [-DMIN_BACKWARD=<n>: require at least n backward crossings]
#   [-DMIN_RECURSIONS=<n>: require at least n recursive continuations]
if(NOT DEFINED SCENARIO)
  set(SCENARIO config/scenarios/skin_incision.yaml)
endif()
foreach(run a b)
  execute_process(COMMAND ${SCALPELSIM} replay ${SCENARIO} ${LOG} --no-progress
                          --out ${OUT}/${run} RESULT_VARIABLE code
                  OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT code EQUAL 0)
    message(FATAL_ERROR "replay ${run} failed (${code}):\n${out}${err}")
  endif()
endforeach()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${OUT}/a/mesh.vtu ${OUT}/b/mesh.vtu RESULT_VARIABLE differ)
if(differ)
  message(FATAL_ERROR "mesh.vtu differs between two replays")
endif()
foreach(run a b)
  file(READ ${OUT}/${run}/report.json report)
  string(JSON report REMOVE "${report}" timings)
  set(report_${run} "${report}")
endforeach()
if(NOT report_a STREQUAL report_b)
  message(FATAL_ERROR "report.json (less timings) differs between two replays")
endif()
string(JSON edges GET "${report_a}" cutting edges_cut)
string(JSON ok GET "${report_a}" invariants volume)
if(edges LESS 1 OR NOT ok)
  message(FATAL_ERROR "the default replay cut nothing or broke an invariant")
endif()
string(JSON backward GET "${report_a}" cutting backward_crossings)
string(JSON undone GET "${report_a}" cutting undone_face_subdivisions)
if(DEFINED MIN_BACKWARD AND backward LESS MIN_BACKWARD)
  message(FATAL_ERROR "${backward} backward crossings, expected at least ${MIN_BACKWARD}")
endif()
string(JSON recursions GET "${report_a}" cutting recursive_continuations)
if(DEFINED MIN_RECURSIONS AND recursions LESS MIN_RECURSIONS)
  message(FATAL_ERROR "${recursions} recursive continuations, expected at least ${MIN_RECURSIONS}")
endif()
message(STATUS "two replays identical; ${edges} edges cut, ${backward} backward crossings, ${undone} face "
               "subdivisions undone, ${recursions} recursive continuations")
