# Installs headers, the library and a CMake package, so that another project
# can find_package(dkf) and link dkf::dkf:
#
#   <prefix>/include/dkf/*.h
#   <prefix>/lib/libdkf.a, or with BUILD_SHARED_LIBS=ON
#   <prefix>/lib/libdkf.so -> libdkf.so.<major>.<minor> -> libdkf.so.<version>
#   <prefix>/lib/cmake/dkf/{dkfConfig,dkfConfigVersion,dkfTargets*}.cmake
#
# Included when DKF_INSTALL is on (by default only when dkf is the
# top-level project).
#
# What a consumer must agree on is in the installed dkf/build_config.h,
# generated from this build's options (DKF_USE_FLOAT, DKF_MAX_DIM,
# DKF_JOSEPH, DKF_DEBUG_CHECKS, DKF_SVD_MAX_SWEEPS): it
# sets them, and a consumer that defines another value gets an #error. The
# exported target also carries the DKF_USE_FLOAT / DKF_JOSEPH definitions
# (the same values), libm, and, for a DKF_SANITIZE build, the sanitizer
# runtimes the objects need.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

if(DKF_SANITIZE)
  target_link_options(dkf INTERFACE $<INSTALL_INTERFACE:-fsanitize=address,undefined,float-cast-overflow>)
endif()

# (The include directory reaches the export through the INSTALL_INTERFACE
# of target_include_directories in the top-level CMakeLists.txt.)
install(TARGETS dkf EXPORT dkfTargets ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(DIRECTORY include/dkf DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
  PATTERN build_config.h EXCLUDE)
# ... and in its place the configuration this build compiled libdkf with.
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/include/dkf/build_config.h
  DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/dkf)
install(EXPORT dkfTargets NAMESPACE dkf:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/dkf)
configure_package_config_file(cmake/dkfConfig.cmake.in
  ${CMAKE_CURRENT_BINARY_DIR}/dkfConfig.cmake
  INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/dkf)
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/dkfConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/dkfConfig.cmake ${CMAKE_CURRENT_BINARY_DIR}/dkfConfigVersion.cmake
  DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/dkf)
