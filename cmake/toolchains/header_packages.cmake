# The header-only packages a cross build uses (Eigen, xsimd, nlohmann-json, doctest, CLI11) are the
# build machine's Debian packages: architecture-free headers. Their CMake files are found under
# GLOVEPOSE_HEADER_PACKAGES, a directory tools/cross.sh stages with only those headers in it, never
# under the build machine's /usr (whose /usr/include holds its own C library's headers).
if(NOT GLOVEPOSE_HEADER_PACKAGES AND DEFINED ENV{GLOVEPOSE_HEADER_PACKAGES})
  set(GLOVEPOSE_HEADER_PACKAGES "$ENV{GLOVEPOSE_HEADER_PACKAGES}")
endif()
if(NOT GLOVEPOSE_HEADER_PACKAGES)
  message(FATAL_ERROR "cross toolchain: GLOVEPOSE_HEADER_PACKAGES is not set (expected the directory tools/cross.sh stages)")
endif()
set(ENV{GLOVEPOSE_HEADER_PACKAGES} "${GLOVEPOSE_HEADER_PACKAGES}")  # seen again by try_compile
set(CMAKE_FIND_ROOT_PATH "${GLOVEPOSE_HEADER_PACKAGES}")
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)   # programs (python3, mono) run on the build machine
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
