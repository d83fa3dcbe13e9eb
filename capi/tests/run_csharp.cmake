# Compiles the C# P/Invoke smoke test with Mono's mcs and runs it against the built library.
# Usage: cmake -DMCS=mcs -DMONO=mono -DSOURCE=smoke.cs -DOUT_DIR=dir -DLIBRARY_DIR=dir -DMODEL=model -P run_csharp.cmake
set(exe "${OUT_DIR}/capi_smoke.exe")
execute_process(COMMAND ${MCS} -nologo -warnaserror -out:${exe} ${SOURCE} RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "mcs failed (${rc}) on ${SOURCE}")
endif()
# Mono's DllImport("glovepose_c") finds libglovepose_c.so through the dynamic loader's path.
set(ENV{LD_LIBRARY_PATH} "${LIBRARY_DIR}:$ENV{LD_LIBRARY_PATH}")
execute_process(COMMAND ${MONO} ${exe} ${MODEL} RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the C# smoke test failed (${rc})")
endif()
