# SPDX-License-Identifier: MIT
# What the Debian package (and `cmake --install`) ships beside the library
# (cmake/LbpkitInstall.cmake): the lbpkit tool, its manual page and its bash
# completion; and the package itself, made by CPack:
#   cmake --build build/default && (cd build/default && cpack -G DEB)
#   -> build/default/lbpkit_<version>_amd64.deb
# ctest PackageDeb (tests/package) builds it and installs it into a
# throwaway root.

# `lbpkit --version`: the project's VERSION, from the top-level project(),
# the one place it is written. On main.cpp alone, so a new version compiles
# one file.
set_property(SOURCE ${PROJECT_SOURCE_DIR}/apps/lbpkit/main.cpp DIRECTORY ${PROJECT_SOURCE_DIR}/apps/lbpkit APPEND
             PROPERTY COMPILE_DEFINITIONS LBPKIT_VERSION="${PROJECT_VERSION}")
install(TARGETS lbpkit RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})

# lbpkit(1): docs/man/lbpkit.1.in with its COMMANDS section made from the
# built tool's --help (cmake/LbpkitManPage.cmake), so it never lags behind
# the commands. gzip -n: no time stamp, so the same sources give the same
# package.
find_program(LBPKIT_GZIP gzip REQUIRED)
set(man_page ${PROJECT_BINARY_DIR}/man/lbpkit.1)
add_custom_command(OUTPUT ${man_page} ${man_page}.gz
                   COMMAND ${CMAKE_COMMAND} -DLBPKIT=$<TARGET_FILE:lbpkit>
                           -DTEMPLATE=${PROJECT_SOURCE_DIR}/docs/man/lbpkit.1.in -DOUTPUT=${man_page}
                           -DVERSION=${PROJECT_VERSION} -P ${PROJECT_SOURCE_DIR}/cmake/LbpkitManPage.cmake
                   COMMAND ${LBPKIT_GZIP} -9nkf ${man_page}
                   DEPENDS lbpkit ${PROJECT_SOURCE_DIR}/docs/man/lbpkit.1.in
                           ${PROJECT_SOURCE_DIR}/cmake/LbpkitManPage.cmake
                   COMMENT "Making lbpkit(1) from docs/man/lbpkit.1.in and lbpkit --help"
                   VERBATIM)
# Not in the sanitizers' default build: it would run the instrumented tool
# there, for a page nobody installs from those builds.
if(LBPKIT_SANITIZE OR LBPKIT_TSAN)
  add_custom_target(lbpkit_man_page DEPENDS ${man_page}.gz)
else()
  add_custom_target(lbpkit_man_page ALL DEPENDS ${man_page}.gz)
endif()
install(FILES ${man_page}.gz DESTINATION ${CMAKE_INSTALL_MANDIR}/man1 OPTIONAL)

# Bash completion: subcommands and options, asked of the lbpkit being run
# (its --help), so it needs no updating either. Loaded on demand by Debian's
# bash-completion from this folder.
install(FILES ${PROJECT_SOURCE_DIR}/contrib/bash-completion/lbpkit
        DESTINATION ${CMAKE_INSTALL_DATADIR}/bash-completion/completions)

# The licences: lbpkit's (MIT), what it has compiled in (Chart.js), and the
# third-party configurations in the source tree's tests/, in Debian's
# machine-readable copyright format, where Debian keeps a package's.
install(FILES ${PROJECT_SOURCE_DIR}/packaging/copyright DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/lbpkit)

# The Debian package: one package, lbpkit_<version>_amd64.deb, with the tool
# and the library (shared, static, headers, CMake package, lbpkit.pc).
# Depends comes from dpkg-shlibdeps on the ELF files in it (libc6,
# libstdc++6, libgcc-s1, libfmt9, ...), so it names exactly the libraries
# they load: the web view's page and Chart.js are compiled into lbpkit.
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME lbpkit)
set(CPACK_PACKAGE_VENDOR lbpkit)
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "tools and driver library for the Mesa 7I77 servo/IO system, real or virtual")
set(CPACK_PACKAGE_DESCRIPTION
    "lbpkit talks to a Mesa HostMot2 Ethernet card (such as a 7I92) with 7I77\n"
    "smart-serial remotes, or to a virtual one: card information, discovery,\n"
    "remote parameters, a live monitor and LinuxCNC configuration checks.\n"
    "`lbpkit sim` is a virtual 7I92 + 7I77 on the network that LinuxCNC's\n"
    "hm2_eth and mesaflash use unmodified, with a control API, a web view\n"
    "and simulated machines.\n"
    "\n"
    "Also the C++20 host library (liblbpkit_host, shared and static) with its\n"
    "headers, a CMake package (find_package(lbpkit), lbpkit::host) and\n"
    "lbpkit.pc.")
string(JOIN "" CPACK_PACKAGE_DESCRIPTION ${CPACK_PACKAGE_DESCRIPTION})
set(LBPKIT_PACKAGE_MAINTAINER "lbpkit maintainers <lbpkit@localhost>"
    CACHE STRING "The Maintainer field of the Debian package")
set(CPACK_DEBIAN_PACKAGE_MAINTAINER "${LBPKIT_PACKAGE_MAINTAINER}")
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)  # lbpkit_0.1.0_amd64.deb
set(CPACK_DEBIAN_PACKAGE_SECTION electronics)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# A shlibs file for liblbpkit_host.so.MAJOR.MINOR, and ldconfig run on install.
set(CPACK_DEBIAN_PACKAGE_GENERATE_SHLIBS ON)
set(CPACK_DEBIAN_PACKAGE_GENERATE_SHLIBS_POLICY ">=")
# Only the static library and its CMake target need fmt's development files;
# the real clients are what lbpkit sim is for.
set(CPACK_DEBIAN_PACKAGE_SUGGESTS "libfmt-dev, mesaflash, linuxcnc-uspace, bash-completion")
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
# The Python module (python/, when built) is for one python3 minor version
# (its file name says cpython-3MM), which dpkg-shlibdeps cannot see: an
# extension module does not link libpython.
if(TARGET lbpkit_python AND LBPKIT_PYTHON_EXECUTABLE)
  execute_process(COMMAND ${LBPKIT_PYTHON_EXECUTABLE} -c "import sys; print(sys.version_info[0], sys.version_info[1])"
                  OUTPUT_VARIABLE python_version OUTPUT_STRIP_TRAILING_WHITESPACE COMMAND_ERROR_IS_FATAL ANY)
  string(REPLACE " " ";" python_version "${python_version}")
  list(GET python_version 0 python_major)
  list(GET python_version 1 python_minor)
  math(EXPR python_next "${python_minor} + 1")
  set(CPACK_DEBIAN_PACKAGE_DEPENDS "python3 (>= ${python_major}.${python_minor}~), python3 (<< ${python_major}.${python_next})")
endif()
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_STRIP_FILES ON)
# Installing (and so cpack's preinstall step) takes the tree as built, as the
# README says to build it first: it does not build every target, so that
# scripts/test's optimised build, which leaves the unit tests' executables
# to the ASan build, is packaged without compiling them.
set(CMAKE_SKIP_INSTALL_ALL_DEPENDENCY ON)
include(CPack)
