# Registers subdirectory_consumer and fetchcontent_consumer: a parent project
# (tests/subproject) takes in this source tree with add_subdirectory() /
# FetchContent, configured with nothing but a C compiler, and must get the
# library alone (run_subproject.cmake). Included from the top-level
# CMakeLists.txt when DKF_BUILD_TESTS is on.
#
# They do not depend on this build's options (each configures its own
# Debug build with dkf's defaults): labels build and once
# (cmake/testing.cmake), so that one configuration runs them for all. Not registered when cross-compiling:
# what they check is the build system's, and the native configurations
# check it.
if(NOT CMAKE_CROSSCOMPILING)
  foreach(_via add_subdirectory FetchContent)
    string(TOLOWER "${_via}" _name)
    string(REGEX REPLACE "^add_" "" _name "${_name}_consumer")
    add_test(NAME ${_name} COMMAND ${CMAKE_COMMAND}
      -DDKF_TEST_NAME=${_name}
      -DDKF_SOURCE_DIR=${PROJECT_SOURCE_DIR}
      -DDKF_SUBPROJECT_SOURCE=${CMAKE_CURRENT_LIST_DIR}
      -DDKF_WORK_DIR=${PROJECT_BINARY_DIR}/subproject-test
      -DDKF_C_COMPILER=${CMAKE_C_COMPILER}
      -DDKF_VIA=${_via}
      -P ${CMAKE_CURRENT_LIST_DIR}/run_subproject.cmake)
    # Each builds the library with -j2.
    set_tests_properties(${_name} PROPERTIES TIMEOUT 600 PROCESSORS 2)
    dkf_label_tests(build once TESTS ${_name})
  endforeach()
endif()
