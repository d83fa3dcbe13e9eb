# Cross-build for Windows x64 with Debian's mingw-w64 (the POSIX-threads g++, for std::thread);
# tests run under Debian's Wine. Used by tools/cross.sh windows, which also stages the header-only
# packages.
set(CMAKE_SYSTEM_NAME Windows)
set(CMAKE_SYSTEM_PROCESSOR x86_64)
set(CMAKE_C_COMPILER x86_64-w64-mingw32-gcc-posix)
set(CMAKE_CXX_COMPILER x86_64-w64-mingw32-g++-posix)
set(CMAKE_RC_COMPILER x86_64-w64-mingw32-windres)
set(CMAKE_CROSSCOMPILING_EMULATOR wine)
include(${CMAKE_CURRENT_LIST_DIR}/header_packages.cmake)
# The GCC runtime (libstdc++, libgcc, winpthread) linked in: glovepose_c.dll and the executables
# need no MinGW DLL beside them, as engines ship a DLL alone.
set(CMAKE_EXE_LINKER_FLAGS_INIT "-static")
set(CMAKE_SHARED_LINKER_FLAGS_INIT "-static")
list(APPEND CMAKE_FIND_ROOT_PATH /usr/x86_64-w64-mingw32)
