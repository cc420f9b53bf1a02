# Install rules and package config: find_package(trompo CONFIG) gives trompo::trompo.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

install(TARGETS trompo EXPORT trompoTargets)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/trompo
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(EXPORT trompoTargets
        NAMESPACE trompo::
        DESTINATION ${CMAKE_INSTALL_DATADIR}/cmake/trompo)

configure_package_config_file(
  ${PROJECT_SOURCE_DIR}/cmake/trompoConfig.cmake.in
  ${PROJECT_BINARY_DIR}/trompoConfig.cmake
  INSTALL_DESTINATION ${CMAKE_INSTALL_DATADIR}/cmake/trompo)
# Header-only: the package fits any architecture.
write_basic_package_version_file(
  ${PROJECT_BINARY_DIR}/trompoConfigVersion.cmake
  COMPATIBILITY SameMajorVersion
  ARCH_INDEPENDENT)
install(FILES ${PROJECT_BINARY_DIR}/trompoConfig.cmake
              ${PROJECT_BINARY_DIR}/trompoConfigVersion.cmake
        DESTINATION ${CMAKE_INSTALL_DATADIR}/cmake/trompo)
