# Installs this build into a scratch prefix and runs the installed `glovepose` from there: its
# default models come from the prefix (share/glovepose/models), not the source or build tree.
# Run by CTest (test "installed_tool_finds_its_models").
file(REMOVE_RECURSE "${WORK_DIR}")
set(prefix "${WORK_DIR}/prefix")

execute_process(COMMAND ${CMAKE_COMMAND} --install "${BUILD_DIR}" --prefix "${prefix}" RESULT_VARIABLE rc OUTPUT_QUIET ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cmake --install failed (${rc}): ${err}")
endif()
foreach(file glovepose_fcn512.safetensors glovepose_unet64.safetensors calibration_glauser2019.json)
  if(NOT EXISTS "${prefix}/share/glovepose/models/${file}" OR IS_SYMLINK "${prefix}/share/glovepose/models/${file}")
    message(FATAL_ERROR "the install did not copy models/${file} to ${prefix}/share/glovepose/models")
  endif()
endforeach()

# bench times the shipped FCN and U-Net when no --model is given.
execute_process(COMMAND "${prefix}/bin/glovepose" bench --poses 10 --json RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "installed glovepose bench failed (${rc}):\n${out}\n${err}")
endif()
# The tool names the path it finds itself at (/proc/self/exe): links in the prefix resolved.
file(REAL_PATH "${prefix}" real_prefix)
foreach(model glovepose_fcn512.safetensors glovepose_unet64.safetensors)
  string(FIND "${out}" "${real_prefix}/share/glovepose/models/${model}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "installed glovepose bench did not time ${prefix}/share/glovepose/models/${model}:\n${out}")
  endif()
endforeach()

# Without the installed models it says where it looked.
file(RENAME "${prefix}/share/glovepose/models" "${prefix}/share/glovepose/moved")
execute_process(COMMAND "${prefix}/bin/glovepose" bench --poses 10 RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
string(FIND "${out}${err}" "share/glovepose/models/glovepose_fcn512.safetensors' is missing" at)
if(rc EQUAL 0 OR at EQUAL -1)
  message(FATAL_ERROR "installed glovepose without its models: exit ${rc}, expected an error naming the missing file:\n${out}\n${err}")
endif()
message(STATUS "the installed glovepose found its models in ${prefix}/share/glovepose/models")
