# SPDX-License-Identifier: MIT
# Makes lbpkit(1) (run at build time: cmake -P, see cmake/LbpkitPackage.cmake):
# docs/man/lbpkit.1.in, written by hand, with its COMMANDS section filled in
# from the built tool's own --help, every command (and their subcommands, if
# any) with its description, usage, positionals and options. So the page
# lists exactly the commands and options the lbpkit beside it has.
#
#   cmake -DLBPKIT=path/to/lbpkit -DTEMPLATE=docs/man/lbpkit.1.in -DOUTPUT=lbpkit.1
#         -DVERSION=0.1.0 -P cmake/LbpkitManPage.cmake
cmake_minimum_required(VERSION 3.25)
foreach(var LBPKIT TEMPLATE OUTPUT VERSION)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "LbpkitManPage.cmake: -D${var}=... is missing")
  endif()
endforeach()

# Text from --help as roff: backslashes and option dashes escaped, and no line
# may start with a control character.
function(lbpkit_roff text out)
  string(REPLACE "\\" "\\e" text "${text}")
  string(REPLACE "-" "\\-" text "${text}")
  string(REGEX REPLACE "^([.'])" "\\\\&\\1" text "${text}")
  string(REPLACE "<SEMI>" ";" text "${text}")
  string(REPLACE "<LB>" "[" text "${text}")
  string(REPLACE "<RB>" "]" text "${text}")
  set(${out} "${text}" PARENT_SCOPE)
endfunction()

# Appends the section for `lbpkit WORDS...` to LBPKIT_PAGE, then those of its
# subcommands.
function(lbpkit_man_command)
  set(words ${ARGN})
  execute_process(COMMAND ${LBPKIT} ${words} --help OUTPUT_VARIABLE help RESULT_VARIABLE rc ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "`lbpkit ${words} --help` failed (${rc}): ${err}")
  endif()
  # One list element per line: ; and [ ] would be read as list syntax.
  string(REPLACE ";" "<SEMI>" help "${help}")
  string(REPLACE "[" "<LB>" help "${help}")
  string(REPLACE "]" "<RB>" help "${help}")
  string(REPLACE "\n" ";" lines "${help}")

  set(section "description")
  set(description "")
  set(usage "")
  set(items "")  # one element per item: NAME<TAB>DESCRIPTION
  set(subcommands "")
  set(name "")
  set(text "")
  foreach(line IN LISTS lines)  # ; [ ] stay escaped until lbpkit_roff
    if(line MATCHES "^Usage: [^ ]*lbpkit(.*)$")
      set(usage "lbpkit${CMAKE_MATCH_1}")  # it names the command itself
      set(section "")
    elseif(line MATCHES "^(Options|Positionals|Subcommands):$")
      set(section "${CMAKE_MATCH_1}")
    elseif(section STREQUAL "description")
      if(NOT line STREQUAL "")
        string(APPEND description "${line}\n")
      endif()
    elseif(line MATCHES "^  ([^ ].*)$")  # an item: NAME, two spaces or more, its description
      set(item "${CMAKE_MATCH_1}")
      if(item MATCHES "^(.*[^ ])  +([^ ].*)$")
        set(name "${CMAKE_MATCH_1}")
        set(text "${CMAKE_MATCH_2}")
      else()
        set(name "${item}")
        set(text "")
      endif()
      if(section STREQUAL "Subcommands")
        string(REGEX REPLACE " .*" "" sub "${name}")
        list(APPEND subcommands "${sub}")
      elseif(NOT name MATCHES "^-h,--help$")
        list(APPEND items "${name}\t${text}")
      endif()
    elseif(line MATCHES "^   +([^ ].*)$" AND items)  # the description of a long item, or more of it
      list(POP_BACK items last)
      string(REGEX REPLACE "\t$" "" last "${last}")
      if(last MATCHES "\t")
        string(APPEND last " ${CMAKE_MATCH_1}")
      else()
        string(APPEND last "\t${CMAKE_MATCH_1}")
      endif()
      list(APPEND items "${last}")
    endif()
  endforeach()

  if(words)  # the top level's own text is the page's DESCRIPTION
    string(JOIN " " title lbpkit ${words})
    lbpkit_roff("${title}" title)
    lbpkit_roff("${description}" description)
    lbpkit_roff("${usage}" usage)
    string(APPEND LBPKIT_PAGE ".SS \"${title}\"\n${description}.PP\n.B ${usage}\n")
    foreach(item IN LISTS items)
      set(iname "${item}")
      set(itext "")
      if(item MATCHES "^([^\t]*)\t(.*)$")
        set(iname "${CMAKE_MATCH_1}")
        set(itext "${CMAKE_MATCH_2}")
      endif()
      lbpkit_roff("${iname}" iname)
      lbpkit_roff("${itext}" itext)
      string(APPEND LBPKIT_PAGE ".TP\n.B ${iname}\n${itext}\n")
    endforeach()
  endif()
  if(subcommands)
    list(JOIN subcommands ", " names)
    message(VERBOSE "lbpkit ${words}: ${names}")
  endif()
  foreach(sub IN LISTS subcommands)
    lbpkit_man_command(${words} ${sub})
  endforeach()
  set(LBPKIT_PAGE "${LBPKIT_PAGE}" PARENT_SCOPE)
endfunction()

set(LBPKIT_PAGE "")
lbpkit_man_command()
if(NOT LBPKIT_PAGE MATCHES "\\.SS")
  message(FATAL_ERROR "`${LBPKIT} --help` listed no commands")
endif()
string(REGEX REPLACE "\n$" "" LBPKIT_COMMANDS "${LBPKIT_PAGE}")
set(LBPKIT_VERSION ${VERSION})
configure_file(${TEMPLATE} ${OUTPUT} @ONLY)
