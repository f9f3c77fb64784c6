# The bundled replays against the sha256 of their outputs stored in tests/data/replay_hashes.txt:
# report.json, frames.csv and mesh.vtu as written (what depends on the machine and the build is in
# run.json, not hashed); and the three pictures of --images, drawn by Mesa's llvmpipe whatever GPU the machine has, compared only where
# the Mesa package is the one that drew the stored ones. The replays run in the source tree, with
# the relative paths of tests/cli/bundled_replays.cmake, each twice: the two runs must agree.
#
# Check one replay (a CTest test):
#   cmake -DSCALPELSIM=<program> -DOUT=<folder> -DREPLAY=<name> [-DPICTURES=OFF] -P tests/cli/replay_hashes.cmake
# Rewrite the stored hashes from every replay (scripts/replay-hashes.sh):
#   cmake -DSCALPELSIM=<program> -DOUT=<folder> -DUPDATE=ON -P tests/cli/replay_hashes.cmake
# [-DHASHES=<file>, default: tests/data/replay_hashes.txt]
cmake_minimum_required(VERSION 3.25)
get_filename_component(source_dir "${CMAKE_CURRENT_LIST_DIR}/../.." ABSOLUTE)
include(${CMAKE_CURRENT_LIST_DIR}/bundled_replays.cmake)
if(NOT DEFINED HASHES)
  set(HASHES ${source_dir}/tests/data/replay_hashes.txt)
endif()
if(NOT DEFINED PICTURES)
  set(PICTURES ON)
endif()
set(regenerate "bash scripts/replay-hashes.sh")
set(pictures top.png oblique.png section.png)

# Mesa's software rasterizer draws the pictures: no GPU driver's rounding in the hashes.
set(ENV{LIBGL_ALWAYS_SOFTWARE} 1)
if(EXISTS /usr/share/glvnd/egl_vendor.d/50_mesa.json)
  set(ENV{__EGL_VENDOR_LIBRARY_FILENAMES} /usr/share/glvnd/egl_vendor.d/50_mesa.json)
endif()
execute_process(COMMAND dpkg-query -W -f=\${Version} libgl1-mesa-dri OUTPUT_VARIABLE mesa
                RESULT_VARIABLE no_mesa ERROR_QUIET)
if(no_mesa)
  set(mesa unknown)
endif()

# Replays `name` into `dir`, checks what its log is there to show and sets `<prefix>_<file>` to the
# hash of each output.
function(replay name dir prefix)
  set(scenario ${scalpel_replay_${name}_scenario})
  if(NOT scenario)
    message(FATAL_ERROR "no bundled replay '${name}' (tests/cli/bundled_replays.cmake: ${scalpel_replays})")
  endif()
  set(images)
  if(PICTURES)
    set(images --images)
  endif()
  file(REMOVE_RECURSE ${dir})
  execute_process(COMMAND ${SCALPELSIM} replay ${scenario} ${scalpel_replay_${name}_log} ${images} --no-progress
                          --out ${dir}
                  WORKING_DIRECTORY ${source_dir} RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT code EQUAL 0)
    message(FATAL_ERROR "replay '${name}' failed (${code}):\n${out}${err}")
  endif()
  file(READ ${dir}/report.json report)
  string(JSON edges GET "${report}" cutting edges_cut)
  string(JSON volume GET "${report}" invariants volume)
  string(JSON backward GET "${report}" cutting backward_crossings)
  string(JSON recursions GET "${report}" cutting recursive_continuations)
  if(edges LESS 1 OR NOT volume)
    message(FATAL_ERROR "replay '${name}' cut nothing or broke an invariant (${dir}/report.json)")
  endif()
  set(min_backward ${scalpel_replay_${name}_min_backward})
  if(min_backward AND backward LESS min_backward)
    message(FATAL_ERROR "replay '${name}': ${backward} backward crossings, expected at least ${min_backward}")
  endif()
  set(min_recursions ${scalpel_replay_${name}_min_recursions})
  if(min_recursions AND recursions LESS min_recursions)
    message(FATAL_ERROR "replay '${name}': ${recursions} recursive continuations, expected at least ${min_recursions}")
  endif()
  message(STATUS "replay '${name}': ${edges} edges cut, ${backward} backward crossings, "
                 "${recursions} recursive continuations")
  foreach(file report.json mesh.vtu frames.csv ${pictures})
    if(EXISTS ${dir}/${file})
      file(SHA256 ${dir}/${file} hash)
      set(${prefix}_${file} ${hash} PARENT_SCOPE)
    endif()
  endforeach()
endfunction()

# Replays `name` twice, into `dir`/a and `dir`/b, requires the same outputs and sets
# `<prefix>_<file>` to their hashes.
function(replay_twice name dir prefix)
  replay(${name} ${dir}/a first)
  replay(${name} ${dir}/b second)
  foreach(file report.json mesh.vtu frames.csv ${pictures})
    if(NOT "${first_${file}}" STREQUAL "${second_${file}}")
      message(FATAL_ERROR "replay '${name}': ${file} differs between two runs (${dir}/a and ${dir}/b): "
                          "the replay is not deterministic")
    endif()
    set(${prefix}_${file} ${first_${file}} PARENT_SCOPE)
  endforeach()
endfunction()

# The stored hashes: lines "<sha256>  <replay>/<file>" and "mesa <version>", the package that drew
# the pictures; '#' starts a comment.
set(stored_mesa)
if(EXISTS ${HASHES})
  file(STRINGS ${HASHES} lines REGEX "^([0-9a-f]+  [^ ]+|mesa .+)$")
  foreach(line IN LISTS lines)
    if(line MATCHES "^mesa (.+)$")
      set(stored_mesa ${CMAKE_MATCH_1})
    elseif(line MATCHES "^([0-9a-f]+)  (.+)$")
      set(stored_${CMAKE_MATCH_2} ${CMAKE_MATCH_1})
    endif()
  endforeach()
endif()

if(UPDATE)
  if(NOT PICTURES)
    message(FATAL_ERROR "the stored hashes include the pictures: rewrite them with a scalpelsim that draws them")
  endif()
  set(text "# sha256 of the outputs of the bundled replays (tests/cli/bundled_replays.cmake), run in the
# source tree: report.json, mesh.vtu and frames.csv as written (run.json, with what depends on the
# machine and the build, is not hashed); the pictures of --images,
# drawn by Mesa's llvmpipe from the package named on the line \"mesa\". Builds for the generic
# x86-64 target give these, at -O0 to -O3 (docs/architecture.md, Determinism). Checked by the tests
# cli_replay_*_matches_stored_hashes (tests/cli/replay_hashes.cmake), written by
# scripts/replay-hashes.sh: rewrite it in the commit that changes what a replay produces.
mesa ${mesa}
")
  foreach(name IN LISTS scalpel_replays)
    replay_twice(${name} ${OUT}/${name} now)
    foreach(file mesh.vtu frames.csv report.json ${pictures})
      if(NOT "${now_${file}}" STREQUAL "${stored_${name}/${file}}")
        message(STATUS "${name}/${file}: ${stored_${name}/${file}} -> ${now_${file}}")
      endif()
      string(APPEND text "${now_${file}}  ${name}/${file}\n")
    endforeach()
  endforeach()
  file(WRITE ${HASHES} "${text}")
  message(STATUS "wrote ${HASHES}")
  return()
endif()

replay_twice(${REPLAY} ${OUT} now)
set(compared mesh.vtu frames.csv report.json)
if(NOT PICTURES)
  message(STATUS "pictures not compared: this scalpelsim draws none")
elseif(NOT mesa STREQUAL stored_mesa)
  message(STATUS "pictures not compared: Mesa ${mesa} drew them here, ${stored_mesa} the stored ones")
else()
  list(APPEND compared ${pictures})
endif()
set(differ)
foreach(file IN LISTS compared)
  set(stored "${stored_${REPLAY}/${file}}")
  if(NOT stored)
    string(APPEND differ "  ${file}: no stored hash\n")
  elseif(NOT now_${file} STREQUAL stored)
    string(APPEND differ "  ${file}: stored ${stored}\n  ${file}: now    ${now_${file}}\n")
  endif()
endforeach()
if(differ)
  message(FATAL_ERROR "replay '${REPLAY}' no longer gives the outputs whose hashes ${HASHES} holds:\n${differ}"
                      "The outputs are in ${OUT}/a. If the change "
                      "is meant, rewrite the hashes in the commit that makes it:\n  ${regenerate}")
endif()
string(REPLACE ";" ", " compared "${compared}")
message(STATUS "replay '${REPLAY}': ${compared} match ${HASHES}")
