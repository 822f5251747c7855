# The installed public API: lbpkit::wire and lbpkit::host, their headers in
# include/lbpkit, and a CMake package for find_package(lbpkit). The models,
# servers and adapters are internal and not installed. The targets' own
# install(TARGETS ... EXPORT lbpkitTargets) rules are next to them, in
# src/wire and src/host.
include(CMakePackageConfigHelpers)

set(LBPKIT_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/lbpkit)
install(EXPORT lbpkitTargets NAMESPACE lbpkit:: DESTINATION ${LBPKIT_INSTALL_CMAKEDIR})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/lbpkitConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/lbpkitConfig.cmake
                              INSTALL_DESTINATION ${LBPKIT_INSTALL_CMAKEDIR})
# 0.x: minor versions may break the API.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/lbpkitConfigVersion.cmake
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/lbpkitConfig.cmake ${PROJECT_BINARY_DIR}/lbpkitConfigVersion.cmake
        DESTINATION ${LBPKIT_INSTALL_CMAKEDIR})
