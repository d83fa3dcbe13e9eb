# Installs glovepose (headers and the compiled library) into a scratch prefix and builds + runs a
# separate project that finds it with find_package(glovepose CONFIG REQUIRED): a header-only unit,
# and README's example both header-only and against glovepose::compiled. Run by CTest (test
# "install_and_consume"; MODEL is the shipped model the example loads).
file(REMOVE_RECURSE "${WORK_DIR}")
set(prefix "${WORK_DIR}/prefix")

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "command failed (${rc}): ${ARGN}\n${out}\n${err}")
  endif()
endfunction()

run(${CMAKE_COMMAND} -S "${SOURCE_DIR}" -B "${WORK_DIR}/library" -DCMAKE_CXX_COMPILER=${CXX_COMPILER}
    -DCMAKE_INSTALL_PREFIX=${prefix} -DGLOVEPOSE_BUILD_TESTS=OFF -DGLOVEPOSE_BUILD_BENCHMARKS=OFF
    -DGLOVEPOSE_BUILD_EXAMPLES=OFF -DGLOVEPOSE_BUILD_TOOLS=OFF -DCMAKE_BUILD_TYPE=Release)
run(${CMAKE_COMMAND} --build "${WORK_DIR}/library" --target glovepose_compiled)
run(${CMAKE_COMMAND} --install "${WORK_DIR}/library")
run(${CMAKE_COMMAND} -S "${SOURCE_DIR}/tests/consumer" -B "${WORK_DIR}/consumer" -DCMAKE_CXX_COMPILER=${CXX_COMPILER}
    -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF -DCMAKE_BUILD_TYPE=Release)
run(${CMAKE_COMMAND} --build "${WORK_DIR}/consumer")
run("${WORK_DIR}/consumer/consumer")
run("${WORK_DIR}/consumer/readme_header_only" "${MODEL}")
run("${WORK_DIR}/consumer/readme_compiled" "${MODEL}")
message(STATUS "consumer project built against ${prefix} and ran")
