#!/usr/bin/env bash
# Installs the Debian packages glovepose needs to build and test, skipping those already present.
# Usage: tools/setup.sh [EXTRA_PACKAGE ...]   (extra Debian packages to ensure as well)
set -euo pipefail
# python3-torch: the PyTorch reference the numerics tests compare with (Debian's, for /usr/bin/python3).
# libopenblas0-pthread: the BLAS Debian's PyTorch then uses (it links the reference libblas3 otherwise:
#   a 1024x1024 float product at 6 GFLOP/s instead of 174 on 2 cores).
# mono-mcs: the C# compiler (and Mono runtime) of the C# package's test (capi_csharp).
# clang: tools/test.sh builds and runs the suite with clang as well (warnings are errors in CI).
# libopenxr-dev: <openxr/openxr.h>, the OpenXR joint layout's test compares our structs with it.
# nlohmann-json3-dev: JSON, for the file formats the library reads (model files, glove descriptions) and the tools.
# libcli11-dev: CLI11, the glovepose tool's command-line parsing (the library headers do not need it).
# python3-pip, python3-setuptools, python3-venv: `pip install ./python` (the Python package) into a
#   virtual environment (Debian's pip refuses the system's Python, PEP 668) without any registry.
# ccache: tools/test.sh and tools/cross.sh compile through it (objects kept between runs).
# chromium: the browser test opens glovepose view's page headless (tests/python/test_view.py).
# npm: installs the JavaScript glovepose view's page runs (three.js, tools/cli/web), embedded at build time
#   (Debian's, unless one is there already, e.g. with NodeSource's nodejs, which bundles it).
packages=(cmake make g++ clang libeigen3-dev libxsimd-dev doctest-dev libbenchmark-dev python3-torch libopenblas0-pthread python3-numpy mono-mcs
          libopenxr-dev nlohmann-json3-dev libcli11-dev python3-pip python3-setuptools python3-venv chromium ccache "$@")
command -v npm >/dev/null || packages+=(npm)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
# The view page's JavaScript from the npm registry, as tools/cli/web/package-lock.json pins it
# (the build embeds it in the tool; nothing is fetched when it runs): again when the lock changed.
web="$(cd "$(dirname "$0")" && pwd)/cli/web"
if [ ! -f "$web/node_modules/.package-lock.json" ] || [ "$web/package-lock.json" -nt "$web/node_modules/.package-lock.json" ]; then
  (cd "$web" && npm ci --no-audit --no-fund --loglevel=error)
fi
