// The page `glovepose view` serves and the JavaScript it runs, embedded in the tool: the files of
// tools/cli/web (view.html, view.js) and three.js from the npm registry (tools/cli/web/package.json,
// MIT license), written at build time into view_assets.hpp as kViewAssets (path, bytes) by
// tools/cli/web/view_assets.cmake. Nothing is fetched at run time.
#pragma once

#include <cstddef>

namespace glovepose::cli {
struct ViewAsset {
  const char* path;           // as the page asks for it
  const char* const* chunks;  // the file's bytes, null-terminated list
  std::size_t size;
};
}  // namespace glovepose::cli

// A tool built with GLOVEPOSE_VIEW_PAGE=OFF (CMake; tools/demo.sh's new tree, whose packages leave npm
// out) has no page: its view command says so.
#if GLOVEPOSE_VIEW_PAGE
#include "view_assets.hpp"  // kViewAssets
#endif
