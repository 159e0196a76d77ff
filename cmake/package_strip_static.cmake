# CPack pre-build script (cmake/package.cmake): strips the debug sections, .comment and .note
# from the static libraries in the staging folder, as dh_strip does for Debian's -dev packages
# (an ASan, RelWithDebInfo build's libraries are otherwise some hundred megabytes).
find_program(strip_program NAMES strip)
if(NOT strip_program)
  message(FATAL_ERROR "strip not found (install binutils)")
endif()
file(GLOB_RECURSE archives "${CPACK_TEMPORARY_DIRECTORY}/*.a")
foreach(archive ${archives})
  execute_process(COMMAND ${strip_program} --strip-debug --remove-section=.comment
                          --remove-section=.note --enable-deterministic-archives ${archive}
                  RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "strip ${archive} failed (${rc})")
  endif()
endforeach()
