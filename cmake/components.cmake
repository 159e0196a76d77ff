# Optional components: tools and libraries beyond the core dependencies that some parts of
# scaratwin, and the tests that check those parts, need (the AVR emulator, the cross compiler,
# npm, a browser, ...). Each is declared once, where it is looked for, with one line:
#
#   scaratwin_component(<name> <found> FOR "<what needs it>" INSTALL "<Debian packages>")
#
# A missing component skips its part with a warning. With SCARATWIN_REQUIRE_ALL=ON (the ci
# preset) configuring fails instead, naming every missing component and its packages, so a
# suite can never drop out of CI unnoticed (scripts/test.sh also checks the number of
# registered tests against tests/minimum_test_count).
option(SCARATWIN_REQUIRE_ALL
       "Fail at configure time when an optional component (and the tests that need it) is missing"
       OFF)

function(scaratwin_component name found)
  cmake_parse_arguments(PARSE_ARGV 2 arg "" "FOR;INSTALL" "")
  if(NOT arg_FOR OR NOT arg_INSTALL)
    message(FATAL_ERROR "scaratwin_component(${name}): give FOR \"<what needs it>\" and "
                        "INSTALL \"<Debian packages>\"")
  endif()
  set_property(GLOBAL APPEND PROPERTY SCARATWIN_COMPONENTS_DECLARED ${name})
  if(found)
    return()
  endif()
  set(line "${name} (needed by ${arg_FOR}): install ${arg_INSTALL} (scripts/install-deps.sh)")
  set_property(GLOBAL APPEND PROPERTY SCARATWIN_COMPONENTS_MISSING "${line}")
  if(NOT SCARATWIN_REQUIRE_ALL)
    message(WARNING "missing optional component ${line}; that part is skipped")
  endif()
endfunction()

# Called once at the end of the top-level CMakeLists.txt.
function(scaratwin_check_components)
  if(NOT SCARATWIN_REQUIRE_ALL)
    return()
  endif()
  set(problems "")
  # options that drop whole suites
  foreach(opt SCARATWIN_BUILD_TESTS SCARATWIN_BUILD_FIRMWARE)
    if(DEFINED ${opt} AND NOT ${opt})
      list(APPEND problems "${opt}=OFF leaves tests out")
    endif()
  endforeach()
  get_property(missing GLOBAL PROPERTY SCARATWIN_COMPONENTS_MISSING)
  list(APPEND problems ${missing})
  if(problems)
    list(JOIN problems "\n  " text)
    message(FATAL_ERROR "SCARATWIN_REQUIRE_ALL=ON (the ci preset): every component a test "
                        "needs must be present, but:\n  ${text}")
  endif()
  get_property(declared GLOBAL PROPERTY SCARATWIN_COMPONENTS_DECLARED)
  list(JOIN declared ", " text)
  message(STATUS "optional components all present: ${text}")
endfunction()
