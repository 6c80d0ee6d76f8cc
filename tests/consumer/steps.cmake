# Shared by the cmake -P scripts of the install and subproject consumer tests
# (run_consumer.cmake, run_shared.cmake, tests/subproject/run_subproject.cmake).
# The including script sets `test_name` (the ctest name its messages start
# with).
# (A cmake -P script starts with every policy unset; the functions below
# keep these settings.)
cmake_policy(VERSION 3.25)

# require_defined(var...): stops the script unless every var was given (-D).
function(require_defined)
  foreach(v IN LISTS ARGN)
    if(NOT DEFINED ${v})
      get_filename_component(script "${CMAKE_SCRIPT_MODE_FILE}" NAME)
      message(FATAL_ERROR "${script}: -D${v}=... is required")
    endif()
  endforeach()
endfunction()

# run_step(what command...): runs the command, fails the test with its
# output unless it exits 0; its output is left in `step_output`.
function(run_step what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${test_name}: ${what} failed (${rc}):\n${out}")
  endif()
  message(STATUS "${test_name}: ${what}: ok")
  set(step_output "${out}" PARENT_SCOPE)
endfunction()

# check_installed_list(prefix): the files under `prefix` must be exactly the
# list of docs/guide/build.md ("Installing", the block after <!-- installed-files -->):
# `lib*/` counts as lib/; <config> is DKF_CONFIG in lower case, <version>
# DKF_VERSION and <soversion> its major.minor; entries marked "(ports)" are
# expected when DKF_BUILD_PORTS is on, "(shared)" when DKF_SHARED is, and
# "(static)" when it is not.
function(check_installed_list prefix)
  file(READ ${DKF_SOURCE_DIR}/docs/guide/build.md doc)
  string(FIND "${doc}" "<!-- installed-files -->" at)
  if(at LESS 0)
    message(FATAL_ERROR "${test_name}: docs/guide/build.md has no <!-- installed-files --> list")
  endif()
  string(SUBSTRING "${doc}" ${at} -1 doc)
  string(REGEX MATCH "```text\n([^`]*)```" block "${doc}")
  string(REGEX REPLACE "\n$" "" block "${CMAKE_MATCH_1}")
  string(REPLACE "\n" ";" lines "${block}")
  string(TOLOWER "${DKF_CONFIG}" cfg)
  string(REGEX MATCH "^[0-9]+[.][0-9]+" soversion "${DKF_VERSION}")
  set(tags)
  if(DKF_BUILD_PORTS)
    list(APPEND tags ports)
  endif()
  if(DKF_SHARED)
    list(APPEND tags shared)
  else()
    list(APPEND tags static)
  endif()
  set(want)
  foreach(l IN LISTS lines)
    if(l MATCHES "^(.*) [(]([a-z]+)[)]$")
      if(NOT CMAKE_MATCH_2 IN_LIST tags)
        continue()
      endif()
      set(l "${CMAKE_MATCH_1}")
    endif()
    string(REPLACE "<config>" "${cfg}" l "${l}")
    string(REPLACE "<version>" "${DKF_VERSION}" l "${l}")
    string(REPLACE "<soversion>" "${soversion}" l "${l}")
    list(APPEND want "${l}")
  endforeach()
  file(GLOB_RECURSE got RELATIVE ${prefix} ${prefix}/*)
  list(TRANSFORM got REPLACE "^lib[^/]*/" "lib/")
  list(SORT want)
  list(SORT got)
  if(NOT want STREQUAL got)
    set(extra ${got})
    list(REMOVE_ITEM extra ${want})
    set(missing ${want})
    list(REMOVE_ITEM missing ${got})
    message(FATAL_ERROR "${test_name}: cmake --install and docs/guide/build.md disagree.\n"
      "  installed, not in the docs: ${extra}\n  in the docs, not installed: ${missing}")
  endif()
  list(LENGTH got count)
  message(STATUS "${test_name}: the ${count} installed files are docs/guide/build.md's list: ok")
endfunction()
