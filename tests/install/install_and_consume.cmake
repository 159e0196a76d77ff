# Run by the test install.consumer (tests/install/CMakeLists.txt) with cmake -P.
cmake_minimum_required(VERSION 3.25)

function(run)
  cmake_parse_arguments(R "" "EXPECT;WORKING_DIRECTORY;OUTPUT" "COMMAND" ${ARGN})
  if(NOT DEFINED R_EXPECT)
    set(R_EXPECT 0)
  endif()
  if(NOT R_WORKING_DIRECTORY)
    set(R_WORKING_DIRECTORY ${WORK_DIR})
  endif()
  string(REPLACE ";" " " shown "${R_COMMAND}")
  message(STATUS "$ ${shown}")
  execute_process(COMMAND ${R_COMMAND} WORKING_DIRECTORY ${R_WORKING_DIRECTORY}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc STREQUAL "${R_EXPECT}")
    message(FATAL_ERROR "exit status ${rc}, expected ${R_EXPECT}\n--- stdout\n${out}\n--- stderr\n${err}")
  endif()
  if(R_OUTPUT)
    set(${R_OUTPUT} "${out}${err}" PARENT_SCOPE)
  endif()
endfunction()

function(expect_file path)
  if(NOT EXISTS "${path}")
    message(FATAL_ERROR "the installed tree has no ${path}")
  endif()
endfunction()

function(expect_match text needle what)
  string(FIND "${text}" "${needle}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "${what}: expected to find '${needle}' in:\n${text}")
  endif()
endfunction()

set(prefix ${WORK_DIR}/prefix)
set(moved ${WORK_DIR}/moved-prefix)
set(empty ${WORK_DIR}/empty)
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR} ${empty})

# 1. install and check the layout
run(COMMAND ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
set(bins scaratwin scaratwin-sim)
if(WITH_ROBOT)
  list(APPEND bins scaratwin-robot)
endif()
foreach(exe ${bins})
  expect_file(${prefix}/${BINDIR}/${exe})
endforeach()
set(data ${DATADIR}/scaratwin)
expect_file(${prefix}/${data}/config/scara.toml)
expect_file(${prefix}/${data}/config/two_arms.toml)
if(WITH_FIRMWARE)
  foreach(board uno mega)
    foreach(ext elf hex)
      expect_file(${prefix}/${data}/firmware/${board}/scaratwin-fw-${board}.${ext})
    endforeach()
  endforeach()
endif()
if(WITH_WEB)
  expect_file(${prefix}/${data}/web/index.html)
  expect_file(${prefix}/${data}/web/vendor/three/three.module.js)
endif()
expect_file(${prefix}/include/scaratwin/kinematics/kinematics.hpp)
expect_file(${prefix}/${CMAKEDIR}/scaratwinConfig.cmake)
expect_file(${prefix}/${CMAKEDIR}/scaratwinConfigVersion.cmake)
expect_file(${prefix}/${DOCDIR}/LICENSE)
expect_file(${prefix}/${DOCDIR}/README.md)
expect_file(${prefix}/${DATADIR}/bash-completion/completions/scaratwin)
if(PYTHON)
  foreach(f __init__.py _paths.py _core.pyi py.typed)
    expect_file(${prefix}/${PYTHONDIR}/scaratwin/${f})
  endforeach()
endif()

# 2. a moved prefix works: the installed executables find their data beside themselves, run
# from an empty folder with a PATH of the prefix's bin alone
file(RENAME ${prefix} ${moved})
set(env ${CMAKE_COMMAND} -E env --unset=SCARATWIN_CONFIG --unset=SCARATWIN_DATA_DIR
        PATH=${moved}/${BINDIR})
run(COMMAND ${env} scaratwin fk 0.12 0 0 0 WORKING_DIRECTORY ${empty} OUTPUT out)
message(STATUS "${out}")
if(WITH_ROBOT)
  # the emulator's default firmware (shown by --help) is the moved prefix's
  run(COMMAND ${env} scaratwin-robot --help WORKING_DIRECTORY ${empty} OUTPUT out)
  if(WITH_FIRMWARE)
    expect_match("${out}" "${moved}/${data}/firmware/uno/scaratwin-fw-uno.elf"
                 "scaratwin-robot --help")
  endif()
endif()
if(PYTHON)
  # the Python package, from its dist-packages folder in the moved prefix: the prefix's robot
  # description and executables
  set(py_env ${CMAKE_COMMAND} -E env --unset=SCARATWIN_CONFIG --unset=SCARATWIN_DATA_DIR
             PYTHONPATH=${moved}/${PYTHONDIR} ASAN_OPTIONS=detect_leaks=0)
  if(PY_PRELOAD)
    list(APPEND py_env "LD_PRELOAD=${PY_PRELOAD}")
  endif()
  run(COMMAND ${py_env} ${PYTHON} -c
      "import scaratwin as st\nprint(st.default_robot().path, st.bin_dir(), st.fk([0.12, 0, 0, 0])[0])"
      WORKING_DIRECTORY ${empty} OUTPUT out)
  message(STATUS "${out}")
  expect_match("${out}" "${moved}/${data}/config/scara.toml ${moved}/${BINDIR} 0.254"
               "import scaratwin from the moved prefix")
endif()

# 3. a data folder moved on its own: a clear message naming the folder; SCARATWIN_DATA_DIR
# points at its new place
file(RENAME ${moved}/${data} ${WORK_DIR}/data-elsewhere)
run(COMMAND ${env} scaratwin fk 0.12 0 0 0 WORKING_DIRECTORY ${empty} EXPECT 2 OUTPUT out)
expect_match("${out}" "${moved}/${data}" "scaratwin fk with its data folder moved")
expect_match("${out}" "SCARATWIN_DATA_DIR" "scaratwin fk with its data folder moved")
run(COMMAND ${CMAKE_COMMAND} -E env SCARATWIN_DATA_DIR=${WORK_DIR}/data-elsewhere
            ${moved}/${BINDIR}/scaratwin fk 0.12 0 0 0 WORKING_DIRECTORY ${empty})
file(RENAME ${WORK_DIR}/data-elsewhere ${moved}/${data})

# 4. the standalone consumer project against the installed package
run(COMMAND ${CMAKE_COMMAND} -S ${CONSUMER_SRC} -B ${WORK_DIR}/consumer -G ${GENERATOR}
            -DCMAKE_CXX_COMPILER=${CXX_COMPILER} -DCMAKE_PREFIX_PATH=${moved})
run(COMMAND ${CMAKE_COMMAND} --build ${WORK_DIR}/consumer)
run(COMMAND ${WORK_DIR}/consumer/fk_ik OUTPUT out)
message(STATUS "${out}")
expect_match("${out}" "round trip ok" "fk_ik")
file(REMOVE_RECURSE ${WORK_DIR})
