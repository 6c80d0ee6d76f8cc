# cmake -P script behind the `install_consumer` test (see ctest.cmake):
#   1. cmake --install DKF_BUILD_DIR into DKF_WORK_DIR/prefix (fresh); the
#      installed dkf/build_config.h must record this build's DKF_MAX_DIM;
#   2. configure + build DKF_CONSUMER_SOURCE against it (fresh build dir,
#      same compiler / toolchain file as the main build) and run it (through
#      DKF_EMULATOR when cross-compiling);
#   3. the same consumer forced to another DKF_MAX_DIM must fail to compile,
#      with the #error of the installed dkf/build_config.h;
#   4. the library built again from DKF_SOURCE_DIR with DKF_MAX_DIM=16
#      (library only) and installed: its header must say 16, the consumer
#      built against it must run, and one forced to this build's value must
#      fail to compile. So a consumer never gets another dkf_diffkf_msg_t
#      layout than the library it links, silently.
# Fails (non-zero exit) at the first step that does.
set(test_name install_consumer)
include(${CMAKE_CURRENT_LIST_DIR}/steps.cmake)
require_defined(DKF_BUILD_DIR DKF_CONSUMER_SOURCE DKF_WORK_DIR DKF_C_COMPILER DKF_SOURCE_DIR
  DKF_MAX_DIM)
if(NOT DKF_CONFIG)
  set(DKF_CONFIG Release)
endif()
set(other_dim 16)
if(DKF_MAX_DIM EQUAL 16)
  set(other_dim 12)
endif()

set(toolchain_args)
if(DKF_TOOLCHAIN_FILE)
  list(APPEND toolchain_args -DCMAKE_TOOLCHAIN_FILE=${DKF_TOOLCHAIN_FILE}
    # A toolchain file may restrict find_package to its sysroot.
    -DCMAKE_FIND_ROOT_PATH_MODE_PACKAGE=BOTH)
else()
  list(APPEND toolchain_args -DCMAKE_C_COMPILER=${DKF_C_COMPILER})
endif()

# Checks what `prefix` holds, builds the consumer against it (expecting
# DKF_MAX_DIM = dim) and runs it.
function(check_prefix tag prefix dim)
  foreach(f include/dkf/kf.h include/dkf/config.h include/dkf/build_config.h)
    if(NOT EXISTS ${prefix}/${f})
      message(FATAL_ERROR "install_consumer: ${f} was not installed")
    endif()
  endforeach()
  file(STRINGS ${prefix}/include/dkf/build_config.h said REGEX "^#define DKF_BUILT_MAX_DIM ")
  if(NOT said STREQUAL "#define DKF_BUILT_MAX_DIM ${dim}")
    message(FATAL_ERROR "install_consumer: ${tag}: the installed dkf/build_config.h says "
      "'${said}', the library was built with DKF_MAX_DIM=${dim}")
  endif()
  message(STATUS "install_consumer: ${tag}: installed build_config.h says DKF_MAX_DIM ${dim}")
  file(GLOB_RECURSE lib ${prefix}/lib*/libdkf.a)
  file(GLOB_RECURSE cfg ${prefix}/lib*/cmake/dkf/dkfConfig.cmake)
  if(NOT lib OR NOT cfg)
    message(FATAL_ERROR "install_consumer: libdkf.a or dkfConfig.cmake missing under ${prefix}")
  endif()

  set(build ${DKF_WORK_DIR}/build-${tag})
  file(REMOVE_RECURSE ${build})
  run_step("${tag}: configure" ${CMAKE_COMMAND} -S ${DKF_CONSUMER_SOURCE} -B ${build}
    -DCMAKE_BUILD_TYPE=${DKF_CONFIG} -DCMAKE_PREFIX_PATH=${prefix}
    -DCONSUMER_EXPECT_MAX_DIM=${dim} ${toolchain_args})
  run_step("${tag}: build" ${CMAKE_COMMAND} --build ${build} --config ${DKF_CONFIG})
  set(cmd ${build}/dkf_consumer)
  if(DKF_EMULATOR)
    string(REPLACE "|" ";" emu "${DKF_EMULATOR}")
    set(cmd ${emu} ${cmd})
  endif()
  run_step("${tag}: run" ${cmd})
  message(STATUS "${step_output}")
endfunction()

# A consumer that defines DKF_MAX_DIM=forced against `prefix` must not compile.
function(check_mismatch tag prefix forced)
  set(build ${DKF_WORK_DIR}/build-${tag}-mismatch)
  file(REMOVE_RECURSE ${build})
  run_step("${tag}: configure with DKF_MAX_DIM=${forced}" ${CMAKE_COMMAND}
    -S ${DKF_CONSUMER_SOURCE} -B ${build} -DCMAKE_BUILD_TYPE=${DKF_CONFIG}
    -DCMAKE_PREFIX_PATH=${prefix} -DCONSUMER_FORCE_MAX_DIM=${forced} ${toolchain_args})
  execute_process(COMMAND ${CMAKE_COMMAND} --build ${build} --config ${DKF_CONFIG}
    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
  if(rc EQUAL 0)
    message(FATAL_ERROR "install_consumer: ${tag}: a consumer with DKF_MAX_DIM=${forced} "
      "compiled against the installed library; it must be refused")
  endif()
  if(NOT out MATCHES "DKF_MAX_DIM differs from the value libdkf was built with")
    message(FATAL_ERROR "install_consumer: ${tag}: the mismatched consumer failed, but not "
      "with the #error of dkf/build_config.h:\n${out}")
  endif()
  message(STATUS "install_consumer: ${tag}: DKF_MAX_DIM=${forced} refused at build: ok")
endfunction()

# ---- this build ----------------------------------------------------------------
set(prefix ${DKF_WORK_DIR}/prefix)
file(REMOVE_RECURSE ${prefix})
run_step("install" ${CMAKE_COMMAND} --install ${DKF_BUILD_DIR} --prefix ${prefix} --config ${DKF_CONFIG})
check_installed_list(${prefix})
check_prefix(main ${prefix} ${DKF_MAX_DIM})
check_mismatch(main ${prefix} ${other_dim})

# ---- the library once more, with DKF_MAX_DIM = other_dim ------------------------
set(lib_build ${DKF_WORK_DIR}/lib-dim${other_dim})
set(prefix2 ${DKF_WORK_DIR}/prefix-dim${other_dim})
file(REMOVE_RECURSE ${lib_build} ${prefix2})
set(lib_args -S ${DKF_SOURCE_DIR} -B ${lib_build} -DCMAKE_BUILD_TYPE=${DKF_CONFIG}
  -DDKF_MAX_DIM=${other_dim} -DDKF_BUILD_TESTS=OFF -DDKF_BUILD_PORTS=OFF ${toolchain_args})
foreach(v DKF_REAL DKF_JOSEPH DKF_SANITIZE)
  if(DEFINED ${v})
    list(APPEND lib_args -D${v}=${${v}})
  endif()
endforeach()
run_step("dim${other_dim}: configure the library" ${CMAKE_COMMAND} ${lib_args})
run_step("dim${other_dim}: build the library" ${CMAKE_COMMAND} --build ${lib_build} --config ${DKF_CONFIG} -j2)
run_step("dim${other_dim}: install" ${CMAKE_COMMAND} --install ${lib_build} --prefix ${prefix2} --config ${DKF_CONFIG})
check_prefix(dim${other_dim} ${prefix2} ${other_dim})
check_mismatch(dim${other_dim} ${prefix2} ${DKF_MAX_DIM})
