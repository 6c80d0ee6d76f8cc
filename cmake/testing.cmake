# cmake/testing.cmake - the ctest labels (docs/guide/build.md, "Test labels").
#
# Every test has one kind:
#   unit   in-process tests of the core and the host programs' libraries
#          (cmocka, corpus replays): seconds, no processes, no network
#   cli    dkf-run, the examples and the Python tools on files, through this
#          build's programs
#   net    network processes (LCM multicast, ttl=0) inside private network
#          namespaces the test creates: root only, else SKIP
#   bench  the benchmarks' smoke tests
#   build  tests that configure, build or install another project
# and `once` when it does not depend on the configuration (the real type,
# the Joseph form, the sanitizers, DKF_MAX_DIM): tools/run_tests.sh runs
# those in the `double` configuration only, and every other test in every
# configuration (`ctest -LE once`).

# dkf_label_tests(<label>... TESTS <test>...): appends the labels.
function(dkf_label_tests)
  cmake_parse_arguments(L "" "" "TESTS" ${ARGN})
  foreach(t ${L_TESTS})
    set_property(TEST ${t} APPEND PROPERTY LABELS ${L_UNPARSED_ARGUMENTS})
  endforeach()
endfunction()

# dkf_label_rest(<label>): every test of this directory that has no label
# yet gets <label>. Called at the end of a directory's CMakeLists.txt, so a
# test added there later is labelled without a new line.
function(dkf_label_rest label)
  get_property(_tests DIRECTORY PROPERTY TESTS)
  foreach(t ${_tests})
    get_property(_l TEST ${t} PROPERTY LABELS)
    if(NOT _l)
      set_property(TEST ${t} PROPERTY LABELS ${label})
    endif()
  endforeach()
endfunction()
