# Man pages (help2man, from each program's --help) and the Debian packages (CPack DEB):
#
#   scaratwin           Apache-2.0: the command line, the simulator, the libraries, headers and
#                       CMake package, the firmware images, the page, the robot descriptions,
#                       the bash completion (install components runtime and development)
#   scaratwin-emulator  GPL-3.0-or-later: the emulator scaratwin-robot alone (component
#                       emulator); it links libsimavr (GPL-3)
#
# `cpack -G DEB` in the build folder (or `cmake --build <build> --target package`) makes
# scaratwin_<version>-1_<arch>.deb and scaratwin-emulator_<version>-1_<arch>.deb for /usr.
# Each package's Depends come from dpkg-shlibdeps on its executables, plus what they load at run
# time without linking it (below). The Debian files (copyright in DEP-5 form, changelog.Debian.gz)
# are the components deb_scaratwin and deb_emulator, which a plain `cmake --install` leaves out.
# Tested by package.deb (tests/package/).

find_program(SCARATWIN_HELP2MAN help2man)
scaratwin_component(help2man "${SCARATWIN_HELP2MAN}" INSTALL "help2man"
  FOR "the man pages of scaratwin, scaratwin-sim and scaratwin-robot")
find_program(SCARATWIN_GZIP gzip)

set(SCARATWIN_DEB_RELEASE 1)
set(deb_dir ${CMAKE_BINARY_DIR}/debian)
set(man_dir ${CMAKE_BINARY_DIR}/man)

# man pages, gzip -9n as Debian ships them (man reads them so from any prefix)
set(scaratwin_man_summary "digital twin of a desktop SCARA robot")
set(scaratwin-sim_man_summary "simulator of the scaratwin digital twin (MuJoCo, browser UI)")
set(scaratwin-robot_man_summary
    "emulated scaratwin robot: the firmware in simavr behind a serial pty")
set(man_pages)
if(SCARATWIN_HELP2MAN AND SCARATWIN_GZIP)
  foreach(exe scaratwin scaratwin-sim scaratwin-robot)
    if(NOT TARGET ${exe})
      continue()
    endif()
    set(page ${man_dir}/${exe}.1)
    # SCARATWIN_DATA_DIR: the defaults that --help shows are the Debian packages' paths, not
    # this build's
    add_custom_command(OUTPUT ${page}.gz
      COMMAND ${CMAKE_COMMAND} -E make_directory ${man_dir}
      COMMAND ${CMAKE_COMMAND} -E env
              SCARATWIN_DATA_DIR=/usr/${CMAKE_INSTALL_DATADIR}/scaratwin
              ${SCARATWIN_HELP2MAN} --no-info --no-discard-stderr
              --version-string=${PROJECT_VERSION} --name=${${exe}_man_summary}
              --section=1 --output=${page} $<TARGET_FILE:${exe}>
      COMMAND ${SCARATWIN_GZIP} -9nf ${page}
      DEPENDS ${exe}
      COMMENT "man page ${exe}.1 (help2man)"
      VERBATIM)
    list(APPEND man_pages ${page}.gz)
    if(exe STREQUAL "scaratwin-robot")
      set(component emulator)
    else()
      set(component runtime)
    endif()
    install(FILES ${page}.gz DESTINATION ${CMAKE_INSTALL_MANDIR}/man1 COMPONENT ${component})
  endforeach()
endif()

# Debian's changelog.Debian.gz, copyright and lintian overrides for each package
set(deb_files)
foreach(pkg scaratwin scaratwin-emulator)
  set(PKG ${pkg})
  set(VERSION ${PROJECT_VERSION}-${SCARATWIN_DEB_RELEASE})
  configure_file(${PROJECT_SOURCE_DIR}/packaging/debian/changelog.in
                 ${deb_dir}/${pkg}/changelog.Debian @ONLY)
  configure_file(${PROJECT_SOURCE_DIR}/packaging/debian/${pkg}.copyright
                 ${deb_dir}/${pkg}/copyright COPYONLY)
  add_custom_command(OUTPUT ${deb_dir}/${pkg}/changelog.Debian.gz
    COMMAND ${SCARATWIN_GZIP} -9nkf ${deb_dir}/${pkg}/changelog.Debian
    DEPENDS ${deb_dir}/${pkg}/changelog.Debian VERBATIM)
  list(APPEND deb_files ${deb_dir}/${pkg}/changelog.Debian.gz)
  if(pkg STREQUAL "scaratwin")
    set(component deb_scaratwin)
  else()
    set(component deb_emulator)
  endif()
  install(FILES ${deb_dir}/${pkg}/changelog.Debian.gz
                ${deb_dir}/${pkg}/copyright
          DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/${pkg} COMPONENT ${component}
          EXCLUDE_FROM_ALL)
  install(FILES ${PROJECT_SOURCE_DIR}/packaging/debian/${pkg}.lintian-overrides
          DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/lintian/overrides RENAME ${pkg}
          COMPONENT ${component} EXCLUDE_FROM_ALL)
endforeach()
add_custom_target(scaratwin_package_files ALL DEPENDS ${man_pages} ${deb_files})

# CPack ------------------------------------------------------------------------------------
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME scaratwin)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_VENDOR "The scaratwin authors")
set(CPACK_PACKAGE_CONTACT
    "scaratwin maintainers <maintainers@users.noreply.h-seed-3aea2163.example>")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_STRIP_FILES ON)
# dh_strip's treatment of static libraries: their debug sections go, their symbols stay
set(CPACK_PRE_BUILD_SCRIPTS ${CMAKE_CURRENT_LIST_DIR}/package_strip_static.cmake)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_GROUPING ONE_PER_GROUP)
set(CPACK_COMPONENTS_ALL runtime development deb_scaratwin)
if(TARGET scaratwin-robot)
  list(APPEND CPACK_COMPONENTS_ALL emulator deb_emulator)
endif()
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_RELEASE ${SCARATWIN_DEB_RELEASE})
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_COMPRESSION_TYPE xz)
# xz on every core (CPack 3.20+): the package test builds the packages in CI
set(CPACK_THREADS 0)
set(deb_version ${PROJECT_VERSION}-${SCARATWIN_DEB_RELEASE})

set(CPACK_DEBIAN_SCARATWIN_PACKAGE_NAME scaratwin)
# the simulator's camera (and the emulator's webcam) renders through libglvnd's EGL, which
# loads Mesa's EGL (surfaceless platform) and its software rasterizer at run time: no linked
# library names them
set(CPACK_DEBIAN_SCARATWIN_PACKAGE_DEPENDS "libegl-mesa0, libgl1-mesa-dri")
set(CPACK_DEBIAN_SCARATWIN_PACKAGE_RECOMMENDS "scaratwin-emulator (= ${deb_version}), avrdude")
set(CPACK_DEBIAN_SCARATWIN_PACKAGE_SUGGESTS "chromium | firefox-esr")
set(CPACK_DEBIAN_SCARATWIN_DESCRIPTION "digital twin of a desktop SCARA robot
scaratwin develops a robot program against a virtual robot (MuJoCo physics,
camera, gripper, a 3D view in the browser), then runs the same program on the
physical robot (an Arduino Uno with steppers and servos over USB serial) while
the virtual robot mirrors it, and measures how well the two agree.

This package holds the command line scaratwin, the simulator scaratwin-sim,
the firmware images for the Arduino Uno and Mega 2560, the browser page, the
robot descriptions, the C++ libraries with their CMake package and the bash
completion. The emulated robot is in scaratwin-emulator.")

set(CPACK_DEBIAN_SCARATWIN-EMULATOR_PACKAGE_NAME scaratwin-emulator)
set(CPACK_DEBIAN_SCARATWIN-EMULATOR_PACKAGE_DEPENDS
    "scaratwin (= ${deb_version}), libegl-mesa0, libgl1-mesa-dri")
set(CPACK_DEBIAN_SCARATWIN-EMULATOR_PACKAGE_SECTION electronics)
set(CPACK_DEBIAN_SCARATWIN-EMULATOR_DESCRIPTION "emulated robot of the scaratwin digital twin
scaratwin-robot runs the scaratwin firmware in the simavr AVR emulator and
presents its serial port as a pseudo-terminal, so that the digital twin
(scaratwin home, scaratwin demo) drives it exactly like an Arduino on USB. It
models the robot's steppers, endstops, servos, jog buttons and webcam.

It links libsimavr and is licensed GPL-3.0-or-later.")

include(CPack)
cpack_add_component_group(scaratwin)
cpack_add_component_group(scaratwin-emulator)
cpack_add_component(runtime GROUP scaratwin)
cpack_add_component(development GROUP scaratwin)
cpack_add_component(deb_scaratwin GROUP scaratwin)
if(TARGET scaratwin-robot)
  cpack_add_component(emulator GROUP scaratwin-emulator)
  cpack_add_component(deb_emulator GROUP scaratwin-emulator)
endif()
