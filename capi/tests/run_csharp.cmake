# The C# package's test (bindings/csharp): the C reference writes what the C compiler and the C ABI
# say, Mono's mcs compiles the package's Runtime/*.cs with Tests~/PackageTest.cs, and mono runs it
# against the built library.
# Usage: cmake -DMCS=mcs -DMONO=mono -DPACKAGE_DIR=dir -DREFERENCE=exe -DHEADER=glovepose_c.h
#              -DOUT_DIR=dir -DLIBRARY_DIR=dir -DMODEL=model -P run_csharp.cmake
set(malformed "${OUT_DIR}/csharp_malformed.safetensors")
set(reference "${OUT_DIR}/csharp_reference.txt")
file(WRITE ${malformed} "not a safetensors file")
execute_process(COMMAND ${REFERENCE} ${MODEL} ${malformed} ${reference} RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the C reference failed (${rc})")
endif()
file(GLOB sources ${PACKAGE_DIR}/Runtime/*.cs)
set(exe "${OUT_DIR}/PackageTest.exe")
execute_process(COMMAND ${MCS} -nologo -unsafe -warnaserror -out:${exe} ${sources} ${PACKAGE_DIR}/Tests~/PackageTest.cs RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "mcs failed (${rc}) on the package")
endif()
# Mono's DllImport("glovepose_c") finds libglovepose_c.so through the dynamic loader's path.
set(ENV{LD_LIBRARY_PATH} "${LIBRARY_DIR}:$ENV{LD_LIBRARY_PATH}")
execute_process(COMMAND ${MONO} ${exe} ${MODEL} ${reference} ${malformed} ${HEADER} ${PACKAGE_DIR}/package.json RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the C# package test failed (${rc})")
endif()
