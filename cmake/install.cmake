# Installs headers, the library and a CMake package so that another project
# can find_package(dkf) and link dkf::dkf.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)
install(TARGETS dkf EXPORT dkfTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(DIRECTORY include/dkf DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(EXPORT dkfTargets NAMESPACE dkf:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/dkf)
configure_package_config_file(cmake/dkfConfig.cmake.in
  ${CMAKE_CURRENT_BINARY_DIR}/dkfConfig.cmake
  INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/dkf)
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/dkfConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/dkfConfig.cmake ${CMAKE_CURRENT_BINARY_DIR}/dkfConfigVersion.cmake
  DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/dkf)
