# Cross-build for 64-bit ARM Linux with Debian's g++-aarch64-linux-gnu; tests run under qemu-user
# (Debian's qemu-user). Used by tools/cross.sh arm64, which also stages the header-only packages.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
# The target's libraries live in Debian's cross sysroot; -L/lib paths come from the compiler itself.
set(CMAKE_CROSSCOMPILING_EMULATOR qemu-aarch64 -L /usr/aarch64-linux-gnu)
include(${CMAKE_CURRENT_LIST_DIR}/header_packages.cmake)
list(APPEND CMAKE_FIND_ROOT_PATH /usr/aarch64-linux-gnu)  # its libm, libpthread
set(CMAKE_CXX_FLAGS_INIT "-Wno-psabi")  # GCC notes an ABI change of GCC 10.1 on every pair argument
