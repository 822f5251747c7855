# SPDX-License-Identifier: MIT
# Writes OUTPUT, a .cpp defining `std::string_view lbpkit::app::NAME()`
# (declared in embedded_text.hpp) that returns the text of INPUT, so that
# lbpkit carries the file itself and never looks for it beside the binary.
# Run as a script: cmake -DINPUT=... -DOUTPUT=... -DNAME=... -P embed_text.cmake
cmake_minimum_required(VERSION 3.25)
file(READ "${INPUT}" text)
string(FIND "${text}" ")lbpkit_text\"" clash)
if(NOT clash EQUAL -1)
  message(FATAL_ERROR "${INPUT} holds the raw string's end marker")
endif()
set(body "// Generated from ${INPUT} by apps/lbpkit/embed_text.cmake: do not edit.\n#include \"embedded_text.hpp\"\n\nnamespace lbpkit::app {\n\nstd::string_view ${NAME}() {\n  return R\"lbpkit_text(${text})lbpkit_text\";\n}\n\n}  // namespace lbpkit::app\n")
include(${CMAKE_CURRENT_LIST_DIR}/../../cmake/LbpkitWriteIfChanged.cmake)
write_if_changed("${OUTPUT}" "${body}")
