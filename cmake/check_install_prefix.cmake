# Run first by `cmake --install` (install(SCRIPT) in the top CMakeLists.txt): stops with a clear
# message when the prefix cannot be written, instead of a failure halfway through the install.
set(prefix "$ENV{DESTDIR}${CMAKE_INSTALL_PREFIX}")
execute_process(COMMAND ${CMAKE_COMMAND} -E make_directory "${prefix}"
                RESULT_VARIABLE made OUTPUT_QUIET ERROR_QUIET)
set(probe "${prefix}/.scaratwin-install-check")
if(made EQUAL 0)
  execute_process(COMMAND ${CMAKE_COMMAND} -E touch "${probe}"
                  RESULT_VARIABLE touched OUTPUT_QUIET ERROR_QUIET)
endif()
if(NOT made EQUAL 0 OR NOT touched EQUAL 0)
  message(FATAL_ERROR "cannot install scaratwin into '${prefix}': no permission to create or "
                      "write that folder. Install as root (sudo cmake --install ...), or choose "
                      "a prefix you can write: cmake --install <build> --prefix ~/.local")
endif()
file(REMOVE "${probe}")
