# cmake -P script behind the ctests subdirectory_consumer and
# fetchcontent_consumer (ctest.cmake): configures tests/subproject, which
# takes in the dkf tree DKF_SOURCE_DIR by DKF_VIA (add_subdirectory or
# FetchContent), in a fresh DKF_WORK_DIR/<via> with
#   - the C compiler DKF_C_COMPILER and, as the C++ compiler, a path that
#     does not exist (enabling C++ would stop the configure);
#   - pkg-config looking only at an empty directory, and the find_package
#     calls of dkf's tests, port and benchmarks (PkgConfig, Python3,
#     Eigen3) disabled, which stops the configure if one of them is REQUIRED;
# then builds it (a Debug build: the point is what gets built, not how
# fast it runs) and runs its program. Fails at the first step that does.
set(test_name ${DKF_TEST_NAME})
include(${CMAKE_CURRENT_LIST_DIR}/../consumer/steps.cmake)
require_defined(DKF_TEST_NAME DKF_SOURCE_DIR DKF_SUBPROJECT_SOURCE DKF_WORK_DIR DKF_C_COMPILER
  DKF_VIA)

set(work ${DKF_WORK_DIR}/${DKF_VIA})
file(REMOVE_RECURSE ${work})
file(MAKE_DIRECTORY ${work}/empty-pkgconfig)
run_step("configure with a C compiler only, nothing to find"
  ${CMAKE_COMMAND} -E env --unset=PKG_CONFIG_PATH PKG_CONFIG_LIBDIR=${work}/empty-pkgconfig
  ${CMAKE_COMMAND} -S ${DKF_SUBPROJECT_SOURCE} -B ${work}/build -DCMAKE_BUILD_TYPE=Debug
  -DCMAKE_C_COMPILER=${DKF_C_COMPILER} -DCMAKE_CXX_COMPILER=${work}/no-such-c++-compiler
  -DCMAKE_DISABLE_FIND_PACKAGE_PkgConfig=ON -DCMAKE_DISABLE_FIND_PACKAGE_Python3=ON
  -DCMAKE_DISABLE_FIND_PACKAGE_Eigen3=ON
  -DDKF_SOURCE_DIR=${DKF_SOURCE_DIR} -DDKF_VIA=${DKF_VIA})
run_step("build" ${CMAKE_COMMAND} --build ${work}/build -j2)
run_step("run" ${work}/build/dkf_subproject_app)
message(STATUS "${step_output}")
