# SPDX-License-Identifier: MIT
# The dependency rules (docs/architecture.md: Layout), checked when the project is
# configured and built. scripts/check-layers (ctest LayerRules) checks every
# #include by name; these checks make the compiler and CMake enforce them.

# lbpkit_check_layer_links(): each library target gets the include paths of
# what it links and of nothing else, so an #include across a forbidden edge
# fails to compile, as long as no target links (or adds the include folder of)
# more than its layer allows:
#   lbpkit_wire          nothing of ours
#   lbpkit_host          lbpkit_wire                 (fmt PRIVATE; its public headers use neither)
#   lbpkit_models        lbpkit_wire                 (never lbpkit_host)
#   lbpkit_config        lbpkit_models (+ wire)      (toml++ PUBLIC; never host, servers or adapters)
#   lbpkit_servers       lbpkit_models, lbpkit_web, lbpkit_process (+ wire; never lbpkit_host, config or the adapters)
#   lbpkit_web           nothing of ours (the web view's files and event stream, src/servers/web)
#   lbpkit_sim_adapter   lbpkit_host, lbpkit_models
#   lbpkit_linuxcnc      lbpkit_host (+ wire), lbpkit_process (what LinuxCNC's hostmot2 makes of a card: never models)
#   lbpkit_process       nothing of ours             (other programs, this one's CPUs)
# This function fails the configure step when a target links another
# lbpkit_* library outside that list, or names an include folder under src/
# outside its own. Inside lbpkit_models (lbp <- remote <- hostmot2, one
# include root) only scripts/check-layers can tell the folders apart.
function(lbpkit_check_layer_links)
  set(allowed_lbpkit_wire "")
  set(allowed_lbpkit_host lbpkit_wire)
  set(allowed_lbpkit_models lbpkit_wire)
  set(allowed_lbpkit_config lbpkit_models lbpkit_wire)
  set(allowed_lbpkit_servers lbpkit_models lbpkit_wire lbpkit_web lbpkit_process)
  set(allowed_lbpkit_web "")
  set(allowed_lbpkit_sim_adapter lbpkit_host lbpkit_models lbpkit_wire)
  set(allowed_lbpkit_linuxcnc lbpkit_host lbpkit_wire lbpkit_process)
  set(allowed_lbpkit_process "")
  set(src_root ${PROJECT_SOURCE_DIR}/src)
  set(apps_root ${PROJECT_SOURCE_DIR}/apps)
  foreach(target lbpkit_wire lbpkit_host lbpkit_models lbpkit_config lbpkit_servers lbpkit_web lbpkit_sim_adapter lbpkit_linuxcnc
                 lbpkit_process)
    if(NOT TARGET ${target})
      message(FATAL_ERROR "layer rules: target ${target} is gone; update cmake/LbpkitLayers.cmake")
    endif()
    get_target_property(own_dir ${target} SOURCE_DIR)
    foreach(property LINK_LIBRARIES INTERFACE_LINK_LIBRARIES)
      get_target_property(libs ${target} ${property})
      if(NOT libs)
        continue()
      endif()
      foreach(lib IN LISTS libs)
        string(REGEX REPLACE "^\\$<LINK_ONLY:(.*)>$" "\\1" lib "${lib}")
        if(TARGET "${lib}")
          get_target_property(aliased "${lib}" ALIASED_TARGET)
          if(aliased)
            set(lib ${aliased})
          endif()
        endif()
        if(lib MATCHES "^lbpkit" AND NOT lib IN_LIST allowed_${target})
          list(JOIN allowed_${target} ", " may)
          if(NOT may)
            set(may "nothing of ours")
          endif()
          message(FATAL_ERROR "layer rules: ${target} may not link ${lib} (${property}); "
                              "it may link: ${may} (docs/architecture.md: Layout)")
        endif()
      endforeach()
    endforeach()
    foreach(property INCLUDE_DIRECTORIES INTERFACE_INCLUDE_DIRECTORIES)
      get_target_property(dirs ${target} ${property})
      if(NOT dirs)
        continue()
      endif()
      foreach(dir IN LISTS dirs)
        string(REGEX REPLACE "^\\$<BUILD_INTERFACE:(.*)>$" "\\1" dir "${dir}")
        cmake_path(IS_PREFIX src_root "${dir}" NORMALIZE in_src)
        cmake_path(IS_PREFIX apps_root "${dir}" NORMALIZE in_apps)
        cmake_path(IS_PREFIX own_dir "${dir}" NORMALIZE in_own)
        if((in_src OR in_apps) AND NOT in_own)
          message(FATAL_ERROR "layer rules: ${target} may not add the include folder ${dir} (${property}); "
                              "it gets other layers' headers only by linking them (docs/architecture.md: Layout)")
        endif()
      endforeach()
    endforeach()
  endforeach()
endfunction()

# lbpkit_add_header_check(): every public header compiles on its own, seeing
# only the two public include folders (no target is linked, so no other path
# leaks in), with the project's warnings (errors with LBPKIT_WERROR): one
# generated .cpp per header, compiled into the OBJECT library
# lbpkit_header_check, part of the default build. scripts/check-layers --public-headers (run by the same
# target) checks that they include only the standard library and lbpkit/
# headers (the compile alone would let <fmt/...> from /usr/include pass).
function(lbpkit_add_header_check)
  set(include_dirs ${PROJECT_SOURCE_DIR}/src/wire/include ${PROJECT_SOURCE_DIR}/src/host/include)
  set(out_dir ${PROJECT_BINARY_DIR}/header_check)
  set(sources "")
  set(headers "")
  foreach(dir IN LISTS include_dirs)
    file(GLOB_RECURSE found CONFIGURE_DEPENDS RELATIVE ${dir} ${dir}/*.hpp)
    foreach(header IN LISTS found)
      string(REPLACE "/" "__" name "${header}")
      file(CONFIGURE OUTPUT ${out_dir}/${name}.cpp CONTENT "#include \"${header}\"\n")
      list(APPEND sources ${out_dir}/${name}.cpp)
      list(APPEND headers ${dir}/${header})
    endforeach()
  endforeach()
  add_custom_command(OUTPUT ${out_dir}/public-includes.stamp
                     COMMAND ${PROJECT_SOURCE_DIR}/scripts/check-layers --public-headers
                     COMMAND ${CMAKE_COMMAND} -E touch ${out_dir}/public-includes.stamp
                     DEPENDS ${PROJECT_SOURCE_DIR}/scripts/check-layers ${headers}
                     COMMENT "Checking that the public headers include only the standard library and lbpkit/"
                     VERBATIM)
  add_custom_target(lbpkit_public_includes DEPENDS ${out_dir}/public-includes.stamp)
  add_library(lbpkit_header_check OBJECT ${sources})
  target_include_directories(lbpkit_header_check PRIVATE ${include_dirs})
  add_dependencies(lbpkit_header_check lbpkit_public_includes)
endfunction()
