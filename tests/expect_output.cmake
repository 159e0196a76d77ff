# Runs a command and holds it to its exit status as well as its output (ctest's
# PASS_REGULAR_EXPRESSION alone ignores the exit status, so a command that printed the right
# words and then failed would pass):
#
#   cmake -DEXIT=N -DMATCH=REGEX [-DREJECT=REGEX] [-DABSENT=FILE] -P expect_output.cmake -- CMD ARGS...
#
# EXIT: the exit status it must end with; MATCH: a regular expression its output (stdout and
# stderr together) must match; REJECT: one it must not; ABSENT: a file it must not leave
# behind (removed before the run). An argument of the command may not hold a semicolon (a
# CMake list separator).
set(cmd)
set(after_dashes FALSE)
math(EXPR last "${CMAKE_ARGC} - 1")
foreach(i RANGE 1 ${last})
  if(after_dashes)
    list(APPEND cmd "${CMAKE_ARGV${i}}")
  elseif("${CMAKE_ARGV${i}}" STREQUAL "--")
    set(after_dashes TRUE)
  endif()
endforeach()
if(NOT cmd OR NOT DEFINED EXIT OR NOT DEFINED MATCH)
  message(FATAL_ERROR "expect_output.cmake: give -DEXIT=N -DMATCH=REGEX ... -- COMMAND")
endif()
if(DEFINED ABSENT)
  file(REMOVE "${ABSENT}")
endif()
# echoed as it comes (a run cut by ctest's timeout still shows how far it got)
execute_process(COMMAND ${cmd} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out
  ECHO_OUTPUT_VARIABLE ECHO_ERROR_VARIABLE)
set(problems)
if(NOT "${rc}" STREQUAL "${EXIT}")
  list(APPEND problems "it ended with exit status ${rc}, expected ${EXIT}")
endif()
if(NOT out MATCHES "${MATCH}")
  list(APPEND problems "its output does not match: ${MATCH}")
endif()
if(DEFINED REJECT AND out MATCHES "${REJECT}")
  list(APPEND problems "its output matches what it must not: ${REJECT}")
endif()
if(DEFINED ABSENT AND EXISTS "${ABSENT}")
  list(APPEND problems "it left ${ABSENT} behind")
endif()
if(problems)
  list(JOIN problems "; " said)
  message(FATAL_ERROR "${said}")
endif()
