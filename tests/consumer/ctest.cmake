# Registers `install_consumer`: install this build into a prefix under the
# build directory, then configure, build and run tests/consumer against it
# (offline; see run_consumer.cmake). Included from the top-level
# CMakeLists.txt when DKF_BUILD_TESTS and DKF_INSTALL are on.
set(_dkf_consumer_args
  -DDKF_BUILD_DIR=${PROJECT_BINARY_DIR}
  -DDKF_CONSUMER_SOURCE=${CMAKE_CURRENT_LIST_DIR}
  -DDKF_WORK_DIR=${PROJECT_BINARY_DIR}/consumer-test
  -DDKF_C_COMPILER=${CMAKE_C_COMPILER}
  -DDKF_CONFIG=$<CONFIG>
  -DDKF_SOURCE_DIR=${PROJECT_SOURCE_DIR}
  -DDKF_MAX_DIM=${DKF_MAX_DIM}
  -DDKF_REAL=${DKF_REAL}
  -DDKF_JOSEPH=${DKF_JOSEPH}
  -DDKF_SANITIZE=${DKF_SANITIZE}
  -DDKF_BUILD_PORTS=${DKF_BUILD_PORTS})
if(CMAKE_TOOLCHAIN_FILE)
  get_filename_component(_dkf_tc "${CMAKE_TOOLCHAIN_FILE}" ABSOLUTE BASE_DIR "${CMAKE_SOURCE_DIR}")
  list(APPEND _dkf_consumer_args -DDKF_TOOLCHAIN_FILE=${_dkf_tc})
endif()
if(CMAKE_CROSSCOMPILING_EMULATOR)
  # A list would be split by add_test; pass it '|'-separated.
  string(REPLACE ";" "|" _dkf_emu "${CMAKE_CROSSCOMPILING_EMULATOR}")
  list(APPEND _dkf_consumer_args "-DDKF_EMULATOR=${_dkf_emu}")
endif()
add_test(NAME install_consumer
  COMMAND ${CMAKE_COMMAND} ${_dkf_consumer_args} -P ${CMAKE_CURRENT_LIST_DIR}/run_consumer.cmake)
# (It also builds the library once more, with another DKF_MAX_DIM.)
set_tests_properties(install_consumer PROPERTIES TIMEOUT 600 RESOURCE_LOCK dkf_consumer_dir)
dkf_label_tests(build once TESTS install_consumer) # cmake/testing.cmake

# Registers `shared_consumer`: the library alone built with
# BUILD_SHARED_LIBS=ON and installed, and tests/consumer built against it
# and run on libdkf.so (run_shared.cmake). It builds its own Debug library
# with dkf's defaults, whatever this build's options: labels build and
# once (cmake/testing.cmake), so that one configuration runs it for all. Not
# registered when cross-compiling: what it checks is the build system's, and
# the native configurations check it.
if(NOT CMAKE_CROSSCOMPILING)
  add_test(NAME shared_consumer COMMAND ${CMAKE_COMMAND}
    -DDKF_SOURCE_DIR=${PROJECT_SOURCE_DIR}
    -DDKF_CONSUMER_SOURCE=${CMAKE_CURRENT_LIST_DIR}
    -DDKF_WORK_DIR=${PROJECT_BINARY_DIR}/shared-consumer-test
    -DDKF_C_COMPILER=${CMAKE_C_COMPILER}
    -DDKF_VERSION=${PROJECT_VERSION}
    -DDKF_READELF=${CMAKE_READELF}
    -P ${CMAKE_CURRENT_LIST_DIR}/run_shared.cmake)
  set_tests_properties(shared_consumer PROPERTIES TIMEOUT 600 PROCESSORS 2)
  dkf_label_tests(build once TESTS shared_consumer)
endif()
