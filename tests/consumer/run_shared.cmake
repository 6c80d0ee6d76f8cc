# cmake -P script behind the `shared_consumer` test (ctest.cmake):
#   1. the library alone (tests and port off) configured from
#      DKF_SOURCE_DIR with BUILD_SHARED_LIBS=ON in a fresh
#      DKF_WORK_DIR/lib, built and installed into DKF_WORK_DIR/prefix; the
#      installed files must be docs/guide/build.md's list for a shared build, and
#      libdkf.so.<version>'s SONAME libdkf.so.<major>.<minor>;
#   2. tests/consumer configured against that prefix (find_package(dkf)),
#      built, and its executable must name libdkf.so.<major>.<minor> as
#      NEEDED with a run path into the prefix (readelf -d), so that it runs
#      on the installed shared library, not a copy of the code;
#   3. run.
# Debug builds: what is checked is the linking, not the speed. Fails at the
# first step that does.
cmake_minimum_required(VERSION 3.25)
set(test_name shared_consumer)
include(${CMAKE_CURRENT_LIST_DIR}/steps.cmake)
require_defined(DKF_SOURCE_DIR DKF_CONSUMER_SOURCE DKF_WORK_DIR DKF_C_COMPILER DKF_VERSION
  DKF_READELF)
set(DKF_CONFIG Debug)
set(DKF_SHARED ON)
set(DKF_BUILD_PORTS OFF)
string(REGEX MATCH "^[0-9]+[.][0-9]+" soversion "${DKF_VERSION}")

set(lib_build ${DKF_WORK_DIR}/lib)
set(prefix ${DKF_WORK_DIR}/prefix)
set(build ${DKF_WORK_DIR}/build)
file(REMOVE_RECURSE ${lib_build} ${prefix} ${build})
run_step("configure the shared library" ${CMAKE_COMMAND} -S ${DKF_SOURCE_DIR} -B ${lib_build}
  -DCMAKE_BUILD_TYPE=${DKF_CONFIG} -DCMAKE_C_COMPILER=${DKF_C_COMPILER} -DBUILD_SHARED_LIBS=ON
  -DDKF_BUILD_TESTS=OFF -DDKF_BUILD_PORTS=OFF)
run_step("build the shared library" ${CMAKE_COMMAND} --build ${lib_build} -j2)
run_step("install" ${CMAKE_COMMAND} --install ${lib_build} --prefix ${prefix})
check_installed_list(${prefix})

# readelf_dynamic(file var): the (NEEDED), (SONAME), (RUNPATH)/(RPATH) lines of
# the dynamic section.
function(readelf_dynamic file var)
  run_step("readelf -d ${file}" ${DKF_READELF} -d ${file})
  string(REGEX MATCHALL "[(](NEEDED|SONAME|RUNPATH|RPATH)[)][^\n]*" lines "${step_output}")
  set(${var} "${lines}" PARENT_SCOPE)
endfunction()

file(GLOB_RECURSE lib ${prefix}/lib*/libdkf.so.${DKF_VERSION})
readelf_dynamic("${lib}" dyn)
if(NOT dyn MATCHES "[(]SONAME[)] +Library soname: [[]libdkf[.]so[.]${soversion}[]]")
  message(FATAL_ERROR "${test_name}: ${lib} has no SONAME libdkf.so.${soversion}: ${dyn}")
endif()
get_filename_component(libdir "${lib}" DIRECTORY)

run_step("configure the consumer" ${CMAKE_COMMAND} -S ${DKF_CONSUMER_SOURCE} -B ${build}
  -DCMAKE_BUILD_TYPE=${DKF_CONFIG} -DCMAKE_C_COMPILER=${DKF_C_COMPILER}
  -DCMAKE_PREFIX_PATH=${prefix})
run_step("build the consumer" ${CMAKE_COMMAND} --build ${build})
readelf_dynamic(${build}/dkf_consumer dyn)
if(NOT dyn MATCHES "[(]NEEDED[)] +Shared library: [[]libdkf[.]so[.]${soversion}[]]")
  message(FATAL_ERROR "${test_name}: the consumer does not link libdkf.so.${soversion}: ${dyn}")
endif()
string(REGEX MATCH "[(]R(UN)?PATH[)] +Library r(un)?path: [[]([^]]*)[]]" runpath "${dyn}")
string(REPLACE ":" ";" runpath "${CMAKE_MATCH_3}")
if(NOT libdir IN_LIST runpath)
  message(FATAL_ERROR "${test_name}: the consumer's run path does not lead to ${libdir}: ${dyn}")
endif()
message(STATUS "${test_name}: the consumer needs libdkf.so.${soversion} from ${libdir}: ok")
run_step("run" ${build}/dkf_consumer)
message(STATUS "${step_output}")
