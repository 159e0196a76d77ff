# The firmware built for the host (firmware_host.hpp) as a static library named `name`: the
# firmware's sources compiled against the register shims in fuzz/firmware_host/avr (each
# with fw_host_state.h first), and the harness that runs them. Used by the fuzz target
# (fuzz/CMakeLists.txt: clang, instrumented) and by the corpus replay (tests/firmware: the
# normal compiler). `options`: extra compile options (sanitizers, coverage) of the firmware's
# sources; the harness takes the optional third argument's instead (the fuzz target: sanitizers
# without the fuzzer's coverage, so that its time goes to the firmware), else `options` too.
# The codec core the firmware shares with the host comes with the protocol sources the user
# links.
function(scaratwin_firmware_host name options)
  if(ARGC GREATER 2)
    set(harness_options ${ARGV2})
  else()
    set(harness_options ${options})
  endif()
  set(fw ${PROJECT_SOURCE_DIR}/firmware/src)
  set(host ${PROJECT_SOURCE_DIR}/fuzz/firmware_host)
  add_library(${name}_firmware STATIC
    ${fw}/controller.cpp ${fw}/serial.cpp ${fw}/stepper.cpp ${fw}/homing.cpp ${fw}/jog.cpp
    ${fw}/motion.cpp ${fw}/ramp.cpp ${fw}/settings.cpp ${fw}/settings_store.cpp ${fw}/report.cpp
    ${fw}/servo.cpp ${fw}/buttons.cpp ${fw}/clock.cpp ${fw}/companion.cpp ${host}/host_board.cpp)
  # the register shims come before any system header of the same name
  target_include_directories(${name}_firmware BEFORE PRIVATE ${host})
  target_include_directories(${name}_firmware PRIVATE ${fw} ${SCARATWIN_FW_GENERATED_DIR}
    ${PROJECT_SOURCE_DIR}/include)
  target_compile_definitions(${name}_firmware PRIVATE __AVR_ATmega328P__ F_CPU=16000000UL)
  target_compile_options(${name}_firmware PRIVATE -include ${host}/fw_host_state.h ${options})
  add_dependencies(${name}_firmware fw_description)
  # the firmware's dialect (avr-gcc 5.4: gnu++14)
  set_target_properties(${name}_firmware PROPERTIES CXX_STANDARD 14 CXX_EXTENSIONS ON)

  # the harness: the firmware's entry points, the emulator's mechanics, the host's decoder
  add_library(${name} STATIC ${host}/firmware_host.cpp ${PROJECT_SOURCE_DIR}/src/robot/mechanics.cpp)
  target_include_directories(${name} BEFORE PRIVATE ${host})
  target_include_directories(${name} PRIVATE ${fw} ${SCARATWIN_FW_GENERATED_DIR}
    ${PROJECT_SOURCE_DIR}/src/robot ${PROJECT_SOURCE_DIR}/include)
  target_include_directories(${name} INTERFACE ${PROJECT_SOURCE_DIR}/fuzz)
  target_compile_options(${name} PRIVATE ${harness_options})
  target_link_libraries(${name} PRIVATE scaratwin::core PUBLIC ${name}_firmware)
  add_dependencies(${name} fw_description)
endfunction()
