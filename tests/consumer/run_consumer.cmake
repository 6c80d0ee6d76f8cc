# cmake -P script behind the `install_consumer` test (see ctest.cmake):
#   1. cmake --install DKF_BUILD_DIR into DKF_WORK_DIR/prefix (fresh),
#   2. configure + build DKF_CONSUMER_SOURCE against it (fresh build dir,
#      same compiler / toolchain file as the main build),
#   3. run the consumer (through DKF_EMULATOR when cross-compiling).
# Fails (non-zero exit) at the first step that does.
foreach(v DKF_BUILD_DIR DKF_CONSUMER_SOURCE DKF_WORK_DIR DKF_C_COMPILER)
  if(NOT DEFINED ${v})
    message(FATAL_ERROR "run_consumer.cmake: -D${v}=... is required")
  endif()
endforeach()
if(NOT DKF_CONFIG)
  set(DKF_CONFIG Release)
endif()

set(prefix ${DKF_WORK_DIR}/prefix)
set(build ${DKF_WORK_DIR}/build)
file(REMOVE_RECURSE ${prefix} ${build})

function(run_step what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "install_consumer: ${what} failed (${rc}):\n${out}")
  endif()
  message(STATUS "install_consumer: ${what}: ok")
  set(step_output "${out}" PARENT_SCOPE)
endfunction()

run_step("install" ${CMAKE_COMMAND} --install ${DKF_BUILD_DIR} --prefix ${prefix} --config ${DKF_CONFIG})
foreach(f include/dkf/kf.h include/dkf/config.h)
  if(NOT EXISTS ${prefix}/${f})
    message(FATAL_ERROR "install_consumer: ${f} was not installed")
  endif()
endforeach()
file(GLOB_RECURSE lib ${prefix}/lib*/libdkf.a)
file(GLOB_RECURSE cfg ${prefix}/lib*/cmake/dkf/dkfConfig.cmake)
if(NOT lib OR NOT cfg)
  message(FATAL_ERROR "install_consumer: libdkf.a or dkfConfig.cmake missing under ${prefix}")
endif()

set(configure_args -S ${DKF_CONSUMER_SOURCE} -B ${build}
  -DCMAKE_BUILD_TYPE=${DKF_CONFIG} -DCMAKE_PREFIX_PATH=${prefix})
if(DKF_TOOLCHAIN_FILE)
  list(APPEND configure_args -DCMAKE_TOOLCHAIN_FILE=${DKF_TOOLCHAIN_FILE}
    # A toolchain file may restrict find_package to its sysroot.
    -DCMAKE_FIND_ROOT_PATH_MODE_PACKAGE=BOTH)
else()
  list(APPEND configure_args -DCMAKE_C_COMPILER=${DKF_C_COMPILER})
endif()
run_step("configure" ${CMAKE_COMMAND} ${configure_args})
run_step("build" ${CMAKE_COMMAND} --build ${build} --config ${DKF_CONFIG})

set(exe ${build}/dkf_consumer)
set(cmd ${exe})
if(DKF_EMULATOR)
  string(REPLACE "|" ";" emu "${DKF_EMULATOR}")
  set(cmd ${emu} ${exe})
endif()
run_step("run" ${cmd})
message(STATUS "${step_output}")
