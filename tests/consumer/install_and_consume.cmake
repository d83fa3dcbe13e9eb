# Installs the build tree BUILD_DIR (headers, the compiled library it built, the rest of the tree)
# into a scratch prefix and builds + runs a separate project that finds it with
# find_package(glovepose CONFIG REQUIRED): a header-only unit, and README's example both header-only
# and against glovepose::compiled. Run by CTest (test "install_and_consume"; MODEL is the shipped
# model the example loads). The tree's own glovepose_compiled is installed, not a second build of it:
# that is what `cmake --install` gives a user, and it is built for the baseline like every release.
file(REMOVE_RECURSE "${WORK_DIR}")
set(prefix "${WORK_DIR}/prefix")

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "command failed (${rc}): ${ARGN}\n${out}\n${err}")
  endif()
endfunction()

run(${CMAKE_COMMAND} --install "${BUILD_DIR}" --prefix "${prefix}")
# Compiled without a compiler launcher (ccache, which tools/test.sh exports): GCC names the installed
# headers, found as system headers, by their canonical path, the clone's own, while the command line
# names the stable link tools/test.sh builds through. A cache entry of another clone whose headers
# still sit at their old path would then be served with those headers' layout.
run(${CMAKE_COMMAND} -E env --unset=CMAKE_CXX_COMPILER_LAUNCHER --unset=CMAKE_C_COMPILER_LAUNCHER
    ${CMAKE_COMMAND} -S "${SOURCE_DIR}/tests/consumer" -B "${WORK_DIR}/consumer" -DCMAKE_CXX_COMPILER=${CXX_COMPILER}
    -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF -DCMAKE_BUILD_TYPE=Release)
run(${CMAKE_COMMAND} --build "${WORK_DIR}/consumer" --parallel 2)
run("${WORK_DIR}/consumer/consumer")
run("${WORK_DIR}/consumer/readme_header_only" "${MODEL}")
run("${WORK_DIR}/consumer/readme_compiled" "${MODEL}")
message(STATUS "consumer project built against ${prefix} and ran")
