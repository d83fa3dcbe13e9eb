# The C# package's test (bindings/csharp): the C reference writes what the C compiler and the C ABI
# say; Mono's mcs compiles the package's Runtime/*.cs with Tests~/*.cs and the ```csharp blocks of
# capi/README.md (so the page's C# is the tested code); mono runs it against the built library.
# Usage: cmake -DMCS=mcs -DMONO=mono -DPACKAGE_DIR=dir -DREFERENCE=exe -DHEADER=glovepose_c.h
#              -DREADME=capi/README.md -DOUT_DIR=dir -DLIBRARY_DIR=dir -DMODEL=model -P run_csharp.cmake
set(malformed "${OUT_DIR}/csharp_malformed.safetensors")
set(reference "${OUT_DIR}/csharp_reference.txt")
set(range "${OUT_DIR}/csharp_range.txt")
file(WRITE ${malformed} "not a safetensors file")
execute_process(COMMAND ${REFERENCE} ${MODEL} ${malformed} ${reference} ${range} RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the C reference failed (${rc})")
endif()

# The README's C# blocks, one file each (string(FIND) rather than a regex list: the code has ';').
file(READ ${README} text)
set(fence "```csharp\n")
string(LENGTH "${fence}" skip)
set(blocks "")
set(count 0)
string(FIND "${text}" "${fence}" start)
while(NOT start EQUAL -1)
  math(EXPR start "${start} + ${skip}")
  string(SUBSTRING "${text}" ${start} -1 text)
  string(FIND "${text}" "```" end)
  string(SUBSTRING "${text}" 0 ${end} code)
  file(WRITE "${OUT_DIR}/readme_csharp_${count}.cs" "${code}")
  list(APPEND blocks "${OUT_DIR}/readme_csharp_${count}.cs")
  math(EXPR end "${end} + 3")
  string(SUBSTRING "${text}" ${end} -1 text)
  math(EXPR count "${count} + 1")
  string(FIND "${text}" "${fence}" start)
endwhile()
if(count LESS 3)
  message(FATAL_ERROR "${README} has ${count} csharp blocks, expected the C#, Unity and Godot code (3)")
endif()

file(GLOB sources ${PACKAGE_DIR}/Runtime/*.cs ${PACKAGE_DIR}/Tests~/*.cs)
set(exe "${OUT_DIR}/PackageTest.exe")
execute_process(COMMAND ${MCS} -nologo -unsafe -warnaserror -out:${exe} ${sources} ${blocks} RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "mcs failed (${rc}) on the package, its test and ${README}'s C#")
endif()
# Mono's DllImport("glovepose_c") finds libglovepose_c.so through the dynamic loader's path.
set(ENV{LD_LIBRARY_PATH} "${LIBRARY_DIR}:$ENV{LD_LIBRARY_PATH}")
execute_process(COMMAND ${MONO} ${exe} ${MODEL} ${reference} ${malformed} ${HEADER} ${PACKAGE_DIR}/package.json ${range}
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the C# package test failed (${rc})")
endif()
