# avr-gcc cross toolchain (Debian gcc-avr 5.4, binutils-avr, avr-libc) for the firmware.
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR avr)
set(CMAKE_C_COMPILER avr-gcc)
set(CMAKE_CXX_COMPILER avr-g++)
set(CMAKE_ASM_COMPILER avr-gcc)
# with -flto the archiver must be the gcc wrapper that loads the LTO plugin
set(CMAKE_AR avr-gcc-ar CACHE FILEPATH "")
set(CMAKE_RANLIB avr-gcc-ranlib CACHE FILEPATH "")
set(CMAKE_OBJCOPY avr-objcopy CACHE FILEPATH "")
set(CMAKE_SIZE avr-size CACHE FILEPATH "")
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
