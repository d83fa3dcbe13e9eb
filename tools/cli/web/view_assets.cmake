# glovepose view's page and the JavaScript it runs, embedded into the tool at build time (nothing is
# fetched at run time): the page (view.html, view.js, here) and three.js 0.167.1 from the npm
# registry (MIT license, https://threejs.org; package.json and package-lock.json here, installed
# into node_modules by tools/setup.sh's `npm ci`): its self-contained minified module and its orbit
# camera (examples/jsm/controls/OrbitControls.js). three 0.167 is the last release whose package
# ships one self-contained minified module (684 KB); later ones split it into unminified files of
# 2.1 MB.
#
# Two uses of this file: included by tools/CMakeLists.txt (GLOVEPOSE_VIEW_PAGE), it adds the rule that writes
# view_assets.hpp for the glovepose_cli target; run with `cmake -DOUT=... -P`, it writes it: each
# file as raw string literals of under 64 KB (ISO C++'s minimum a compiler must take; -Wpedantic).
set(view_web_files
    "/|view.html"
    "/view.js|view.js"
    "/three.module.min.js|node_modules/three/build/three.module.min.js"
    "/OrbitControls.js|node_modules/three/examples/jsm/controls/OrbitControls.js"
    "/three-LICENSE.txt|node_modules/three/LICENSE")
set(view_web_dir ${CMAKE_CURRENT_LIST_DIR})

if(CMAKE_SCRIPT_MODE_FILE)
  set(text "// Generated at build time by tools/cli/web/view_assets.cmake from the files of tools/cli/web; do not edit.\n")
  string(APPEND text "// Included by view_page.hpp, which declares ViewAsset.\n#pragma once\nnamespace glovepose::cli {\n")
  set(index 0)
  set(table "")
  foreach(entry IN LISTS view_web_files)
    string(REPLACE "|" ";" parts "${entry}")
    list(GET parts 0 url)
    list(GET parts 1 file)
    file(READ "${view_web_dir}/${file}" content)
    string(FIND "${content}" ")GPJS\"" clash)
    if(NOT clash EQUAL -1)
      message(FATAL_ERROR "${view_web_dir}/${file} contains ')GPJS\"', the raw string's end: expected a file without it (change the delimiter)")
    endif()
    string(LENGTH "${content}" size)
    string(APPEND text "inline constexpr const char* kViewAsset${index}[] = {\n")
    set(at 0)
    while(at LESS size)
      string(SUBSTRING "${content}" ${at} 60000 chunk)
      string(APPEND text "R\"GPJS(${chunk})GPJS\",\n")
      math(EXPR at "${at} + 60000")
    endwhile()
    string(APPEND text "nullptr};\n")
    string(APPEND table "    {\"${url}\", kViewAsset${index}, ${size}},\n")
    math(EXPR index "${index} + 1")
  endforeach()
  string(APPEND text "inline constexpr ViewAsset kViewAssets[] = {\n${table}};\n}  // namespace glovepose::cli\n")
  file(WRITE "${OUT}.tmp" "${text}")
  file(COPY_FILE "${OUT}.tmp" "${OUT}" ONLY_IF_DIFFERENT)
  file(REMOVE "${OUT}.tmp")
  return()
endif()

set(view_web_inputs "")
foreach(entry IN LISTS view_web_files)
  string(REPLACE "|" ";" parts "${entry}")
  list(GET parts 1 file)
  if(NOT EXISTS "${view_web_dir}/${file}")
    message(FATAL_ERROR "${view_web_dir}/${file} is missing: glovepose view embeds it, expected tools/setup.sh (or tools/setup.sh --view) "
                        "to have run `npm ci` in tools/cli/web (three.js from the npm registry); GLOVEPOSE_VIEW_PAGE=OFF builds the tool without the page")
  endif()
  list(APPEND view_web_inputs "${view_web_dir}/${file}")
endforeach()
set(view_assets_dir ${CMAKE_CURRENT_BINARY_DIR}/view_assets)
add_custom_command(
  OUTPUT ${view_assets_dir}/view_assets.hpp
  COMMAND ${CMAKE_COMMAND} -DOUT=${view_assets_dir}/view_assets.hpp -P ${view_web_dir}/view_assets.cmake
  DEPENDS ${view_web_inputs} ${view_web_dir}/view_assets.cmake
  COMMENT "Embedding glovepose view's page and three.js")
target_sources(glovepose_cli PRIVATE ${view_assets_dir}/view_assets.hpp)
target_include_directories(glovepose_cli PRIVATE ${view_assets_dir})
