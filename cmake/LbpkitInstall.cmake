# SPDX-License-Identifier: MIT
# The installed public API: the host library (shared and static) with its
# headers in include/lbpkit, a CMake package for find_package(lbpkit) and a
# pkg-config file lbpkit.pc. The models, servers and adapters are internal and
# not installed. The targets' own install(TARGETS ...) rules are next to them,
# in src/wire and src/host:
#   export set lbpkitTargets        lbpkit::host         liblbpkit_host.so (wire folded in)
#   export set lbpkitStaticTargets  lbpkit::host_static  liblbpkit_host.a, and lbpkit::wire
#                                                        liblbpkit_wire.a (it needs fmt to link)
# Two sets, so that the package config can give the shared library on a
# machine without fmt's development files, which only the static one needs.
include(CMakePackageConfigHelpers)

set(LBPKIT_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/lbpkit)
install(EXPORT lbpkitTargets NAMESPACE lbpkit:: DESTINATION ${LBPKIT_INSTALL_CMAKEDIR})
install(EXPORT lbpkitStaticTargets NAMESPACE lbpkit:: DESTINATION ${LBPKIT_INSTALL_CMAKEDIR})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/lbpkitConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/lbpkitConfig.cmake
                              INSTALL_DESTINATION ${LBPKIT_INSTALL_CMAKEDIR})
# 0.x: minor versions may break the API (and the ABI: the SONAME has the minor).
write_basic_package_version_file(${PROJECT_BINARY_DIR}/lbpkitConfigVersion.cmake
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/lbpkitConfig.cmake ${PROJECT_BINARY_DIR}/lbpkitConfigVersion.cmake
        DESTINATION ${LBPKIT_INSTALL_CMAKEDIR})

# lbpkit.pc, relocatable: its prefix is found from where the file is
# (${pcfiledir}), so the same file serves `cmake --install --prefix ANY` and
# the Debian package's /usr.
file(RELATIVE_PATH LBPKIT_PC_TO_PREFIX /${CMAKE_INSTALL_LIBDIR}/pkgconfig /)
string(REGEX REPLACE "/$" "" LBPKIT_PC_TO_PREFIX "${LBPKIT_PC_TO_PREFIX}")
configure_file(${PROJECT_SOURCE_DIR}/packaging/lbpkit.pc.in ${PROJECT_BINARY_DIR}/lbpkit.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/lbpkit.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
