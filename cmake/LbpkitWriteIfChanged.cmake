# SPDX-License-Identifier: MIT
# write_if_changed(FILE TEXT): FILE holds TEXT afterwards, rewritten only
# when it differs, so that a generated source whose text did not change
# compiles nothing again. For the scripts that generate sources
# (src/servers/web/embed_assets.cmake, apps/lbpkit/embed_text.cmake).
function(write_if_changed file text)
  if(EXISTS "${file}")
    file(READ "${file}" old)
    if(old STREQUAL text)
      return()
    endif()
  endif()
  file(WRITE "${file}" "${text}")
endfunction()
