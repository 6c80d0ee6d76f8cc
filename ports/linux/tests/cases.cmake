# ports/linux/tests/cases.cmake - dkf-run as a user meets it: its streamed
# output, and scenario files as test cases. Included by
# ports/linux/CMakeLists.txt.

# --output streams: --every, --format csv, no file after a failed run, and
# memory that does not grow with the steps (docs/decisions.md item 50). Peak
# memory means nothing under the sanitizers: `once` (the double build).
add_test(NAME dkf_run_output_stream
  COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_SOURCE_DIR}/tests/check_output.py
          $<TARGET_FILE:dkf-run> ${PROJECT_SOURCE_DIR}/tests/vectors
          ${CMAKE_CURRENT_BINARY_DIR}/output_stream)
set_tests_properties(dkf_run_output_stream PROPERTIES TIMEOUT 300 LABELS "cli;once")

# Scenario files as test cases: every
# tests/cases/NAME.json with its NAME.expected beside it (dkf-run's options,
# the exit status, a regular expression of the one stderr line; format in
# tests/run_case.sh) is the ctest dkf_run_case_NAME. A new case is a file
# pair, no CMake.
file(GLOB _dkf_cases CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/tests/cases/*.json)
foreach(_case IN LISTS _dkf_cases)
  get_filename_component(_name ${_case} NAME_WE)
  add_test(NAME dkf_run_case_${_name}
    COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/tests/run_case.sh $<TARGET_FILE:dkf-run> ${_case})
  set_tests_properties(dkf_run_case_${_name} PROPERTIES TIMEOUT 30)
endforeach()

# tools/convert_letters.py: an old file of every linear layout converted is
# the shipped vector byte for byte, read with no notice, and dkf-run's output
# is bit for bit the old file's (docs/decisions.md item 54).
add_test(NAME convert_letters
  COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_SOURCE_DIR}/tests/check_convert_letters.py
          $<TARGET_FILE:dkf-run> ${PROJECT_SOURCE_DIR}/tests/vectors
          ${CMAKE_CURRENT_SOURCE_DIR}/tests/cases ${CMAKE_CURRENT_BINARY_DIR}/convert_letters)
set_tests_properties(convert_letters PROPERTIES TIMEOUT 120 LABELS "cli;once")
