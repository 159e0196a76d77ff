# Install rules and the CMake package (find_package(scaratwin CONFIG)), following the GNU
# install directories:
#   <prefix>/bin                       scaratwin, scaratwin-sim, scaratwin-robot
#   <prefix>/lib                       the static libraries
#   <prefix>/include/scaratwin         the public headers
#   <prefix>/lib/cmake/scaratwin       scaratwinConfig.cmake, its version file and the targets
#   <prefix>/share/scaratwin           robot descriptions (config/), firmware images
#                                      (firmware/<board>/, ELF and HEX; firmware/CMakeLists.txt)
#                                      and the built page (web/; src/web/CMakeLists.txt)
#   <prefix>/share/doc/scaratwin       README, docs, licence texts
# The executables find the data folder relative to their own location (data_paths.hpp).
# Components: runtime (command line, simulator, data, docs), emulator (scaratwin-robot,
# GPL-3.0-or-later) and development (libraries, headers, CMake package).
include(CMakePackageConfigHelpers)

set(SCARATWIN_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/scaratwin CACHE STRING
    "Where scaratwinConfig.cmake is installed (relative to the prefix)")

# executables
install(TARGETS scaratwin scaratwin-sim RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
        COMPONENT runtime)
if(TARGET scaratwin-robot)
  install(TARGETS scaratwin-robot RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
          COMPONENT emulator)
endif()

# libraries: scaratwin_<name> is exported as scaratwin::<name> (core and protocol_core carry
# the include folder). warnings is the private compile-flag target that the static libraries
# name in their link interface (no flags reach a consumer through it).
set(scaratwin_libs)
foreach(name core warnings kinematics trajectory config protocol_core protocol transport
        statements vision sim_model sim sim_server plant web db analysis report script process
        hub calibration tracker calibrate fleet_mqtt fleet mcap run_export)
  if(TARGET scaratwin_${name})
    set_target_properties(scaratwin_${name} PROPERTIES EXPORT_NAME ${name})
    list(APPEND scaratwin_libs scaratwin_${name})
  endif()
endforeach()
if(SCARATWIN_SANITIZE)
  # the libraries are instrumented: a program that links them needs the sanitizer runtimes
  target_link_options(scaratwin_core INTERFACE
    $<INSTALL_INTERFACE:-fsanitize=address,undefined>)
endif()
install(TARGETS ${scaratwin_libs} EXPORT scaratwinTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT development
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT development)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/scaratwin
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} COMPONENT development)
install(EXPORT scaratwinTargets NAMESPACE scaratwin:: FILE scaratwinTargets.cmake
        DESTINATION ${SCARATWIN_INSTALL_CMAKEDIR} COMPONENT development)
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/scaratwinConfig.cmake.in
  ${CMAKE_BINARY_DIR}/cmake/scaratwinConfig.cmake
  INSTALL_DESTINATION ${SCARATWIN_INSTALL_CMAKEDIR} PATH_VARS CMAKE_INSTALL_DATADIR)
write_basic_package_version_file(${CMAKE_BINARY_DIR}/cmake/scaratwinConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_BINARY_DIR}/cmake/scaratwinConfig.cmake
              ${CMAKE_BINARY_DIR}/cmake/scaratwinConfigVersion.cmake
        DESTINATION ${SCARATWIN_INSTALL_CMAKEDIR} COMPONENT development)

# data: the robot descriptions (the firmware images and the page are installed beside the rules
# that build them)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/config/ DESTINATION ${CMAKE_INSTALL_DATADIR}/scaratwin/config
        COMPONENT runtime FILES_MATCHING PATTERN "*.toml")

# docs and licence texts
install(FILES ${PROJECT_SOURCE_DIR}/README.md ${PROJECT_SOURCE_DIR}/LICENSE
        DESTINATION ${CMAKE_INSTALL_DOCDIR} COMPONENT runtime)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/docs/ DESTINATION ${CMAKE_INSTALL_DOCDIR}/docs
        COMPONENT runtime)
install(FILES ${PROJECT_SOURCE_DIR}/examples/sort.txt
        DESTINATION ${CMAKE_INSTALL_DOCDIR}/examples COMPONENT runtime)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/examples/consumer
        DESTINATION ${CMAKE_INSTALL_DOCDIR}/examples COMPONENT development)
if(TARGET scaratwin-robot)
  install(FILES ${PROJECT_SOURCE_DIR}/LICENSE.GPL-3.0 DESTINATION ${CMAKE_INSTALL_DOCDIR}
          COMPONENT emulator)
endif()

# bash completion (bash-completion loads a file named after the command on first use)
foreach(cmd scaratwin scaratwin-sim scaratwin-robot)
  if(TARGET ${cmd})
    if(cmd STREQUAL "scaratwin-robot")
      set(component emulator)
    else()
      set(component runtime)
    endif()
    install(FILES ${PROJECT_SOURCE_DIR}/scripts/completion/scaratwin.bash
            DESTINATION ${CMAKE_INSTALL_DATADIR}/bash-completion/completions RENAME ${cmd}
            COMPONENT ${component})
  endif()
endforeach()
