// The page `glovepose view` serves and the JavaScript it runs, embedded in the tool: the files of
// tools/cli/web (view.html, view.js) and three.js from the npm registry (tools/cli/web/package.json,
// MIT license), written at build time into view_assets.hpp as kViewAssets (path, bytes) by
// tools/cli/web/view_assets.cmake. Nothing is fetched at run time.
#pragma once

#include "view_assets.hpp"
