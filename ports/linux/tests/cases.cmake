# ports/linux/tests/cases.cmake - dkf-run as a user meets it: its streamed
# output, and its tests as data: the refused inputs and failed runs of
# tests/cases/, the comparisons with the vectors of tests/runs.table.
# Included by ports/linux/CMakeLists.txt.

# --output streams: --every, --format csv, no file after a failed run, and
# memory that does not grow with the steps (docs/decisions.md item 50). Peak
# memory means nothing under the sanitizers: `once` (the double build).
add_test(NAME dkf_run_output_stream
  COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_SOURCE_DIR}/tests/check_output.py
          $<TARGET_FILE:dkf-run> ${PROJECT_SOURCE_DIR}/tests/vectors
          ${CMAKE_CURRENT_BINARY_DIR}/output_stream)
set_tests_properties(dkf_run_output_stream PROPERTIES TIMEOUT 300 LABELS "cli;once")

# Where the data's placeholders point (tests/run_case.sh, tests/runs.table).
set(_dkf_case_vars @vectors=${PROJECT_SOURCE_DIR}/tests/vectors
  @scenarios=${PROJECT_SOURCE_DIR}/scenarios @generated=${CMAKE_CURRENT_BINARY_DIR}/test-out
  @out=${CMAKE_CURRENT_BINARY_DIR}/test-out @DKF_MAX_DIM=${DKF_MAX_DIM})

# dkf-run invocations as test cases: every tests/cases/NAME.expected (the
# input, dkf-run's options, the exit status, a regular expression of the one
# stderr line; format in tests/run_case.sh) is the ctest dkf_run_case_NAME.
# Its input is NAME.json beside it unless `input:` names a vector file
# (@vectors/...), a scenario (@scenarios/...) or a file a fixture generates
# (@generated/..., with `fixture:`). A new case is a file pair (or one
# .expected file), no CMake.
file(GLOB _dkf_cases CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/tests/cases/*.expected)
foreach(_case IN LISTS _dkf_cases)
  get_filename_component(_name ${_case} NAME_WE)
  file(STRINGS ${_case} _fixture REGEX "^fixture: ")
  file(STRINGS ${_case} _below REGEX "^max_dim_below: ")
  string(REPLACE "max_dim_below: " "" _below "${_below}")
  if(_below AND NOT DKF_MAX_DIM LESS _below)
    continue()
  endif()
  add_test(NAME dkf_run_case_${_name}
    COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/tests/run_case.sh $<TARGET_FILE:dkf-run> ${_case}
            ${_dkf_case_vars})
  set_tests_properties(dkf_run_case_${_name} PROPERTIES TIMEOUT 30)
  if(_fixture)
    string(REPLACE "fixture: " "" _fixture "${_fixture}")
    set_tests_properties(dkf_run_case_${_name} PROPERTIES FIXTURES_REQUIRED ${_fixture})
  endif()
endforeach()

# dkf-run against the golden vectors: every row of tests/runs.table (format
# in its head) is one ctest, run by tests/run_check.sh; a `differs` row must
# fail its comparison (tests/expect_fail.sh 1).
# dkf_case_words(<var> <text>): <text> with every @tolerance and @folder of
# _dkf_case_vars replaced, split into words as a shell would.
function(dkf_case_words var text)
  set(_s "${text} ")
  foreach(_kv IN LISTS _dkf_case_vars)
    string(REGEX MATCH "^[^=]*" _k "${_kv}")
    string(REGEX REPLACE "^[^=]*=" "" _v "${_kv}")
    string(REPLACE "${_k}/" "${_v}/" _s "${_s}")
    string(REPLACE "${_k} " "${_v} " _s "${_s}")
  endforeach()
  separate_arguments(_s UNIX_COMMAND "${_s}")
  set(${var} "${_s}" PARENT_SCOPE)
endfunction()
file(STRINGS ${CMAKE_CURRENT_SOURCE_DIR}/tests/runs.table _dkf_rows
  REGEX "^(tol|same|differs) [|] ")
set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS tests/runs.table)
foreach(_row IN LISTS _dkf_rows)
  string(REPLACE " | " ";" _f "${_row}")
  list(GET _f 0 _kind)
  list(GET _f 1 _name)
  if(_kind STREQUAL "tol")
    if(DKF_REAL STREQUAL "float")
      list(GET _f 3 _v)
    else()
      list(GET _f 2 _v)
    endif()
    list(APPEND _dkf_case_vars "@${_name}=${_v}")
    continue()
  endif()
  list(GET _f 2 _fixtures)
  list(GET _f 3 _run)
  list(GET _f 4 _cmp)
  dkf_case_words(_run "${_run}")
  dkf_case_words(_cmp "${_cmp}")
  set(_expect)
  if(_kind STREQUAL "differs")
    set(_expect ${CMAKE_CURRENT_SOURCE_DIR}/tests/expect_fail.sh 1 "FAIL")
  endif()
  add_test(NAME ${_name}
    COMMAND ${_expect} ${_check} $<TARGET_FILE:dkf-run> ${Python3_EXECUTABLE} ${_compare}
            ${_out}/${_name}.json --run ${_run} --compare ${_cmp})
  set_tests_properties(${_name} PROPERTIES TIMEOUT 60)
  if(NOT _fixtures STREQUAL "-")
    string(REPLACE "," ";" _fixtures "${_fixtures}")
    set_tests_properties(${_name} PROPERTIES FIXTURES_REQUIRED "${_fixtures}")
  endif()
endforeach()

# tools/convert_letters.py: an old file of every linear layout converted is
# the shipped vector byte for byte, read with no notice, and dkf-run's output
# is bit for bit the old file's (docs/decisions.md item 54).
add_test(NAME convert_letters
  COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_SOURCE_DIR}/tests/check_convert_letters.py
          $<TARGET_FILE:dkf-run> ${PROJECT_SOURCE_DIR}/tests/vectors
          ${CMAKE_CURRENT_SOURCE_DIR}/tests/cases ${CMAKE_CURRENT_BINARY_DIR}/convert_letters)
set_tests_properties(convert_letters PROPERTIES TIMEOUT 120 LABELS "cli;once")
