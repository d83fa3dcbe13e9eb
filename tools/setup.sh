#!/usr/bin/env bash
# Installs the Debian packages glovepose needs, skipping those already present: the one home of the
# package lists, one per purpose, each package with its reason.
# Usage: tools/setup.sh [--demo | --view] [EXTRA_PACKAGE ...]
#   (no option)  everything: build and run every test (tools/test.sh, CI, tools/sanitize.sh, tools/cross.sh)
#   --demo       configure the project and build the glovepose tool without its view page (tools/demo.sh;
#                the tool then needs GLOVEPOSE_VIEW_PAGE=OFF)
#   --view       the same, and the view page's JavaScript: the whole tool, `glovepose view` included
#   EXTRA_PACKAGE  extra Debian packages to ensure as well
set -euo pipefail
purpose=all
case "${1:-}" in
  --demo) purpose=demo; shift ;;
  --view) purpose=view; shift ;;
esac
for arg in "$@"; do
  case "$arg" in
    -*) echo "setup: unknown option '$arg'; usage: tools/setup.sh [--demo | --view] [EXTRA_PACKAGE ...]" >&2; exit 2 ;;
  esac
done
# The glovepose tool: what configuring the project (GLOVEPOSE_BUILD_TESTS=OFF, GLOVEPOSE_BUILD_BENCHMARKS=OFF)
# and building the glovepose_cli target need.
tool_packages=(
  cmake               # the build (3.21 or later)
  make                # CMake's generator here (cmake only recommends it)
  g++                 # C++17; brings gcc, the C compiler the C ABI's example is configured with
  libeigen3-dev       # Eigen 3.4: the library's matrices and the capacitance solve
  libxsimd-dev        # xsimd: the library's SIMD kernels
  nlohmann-json3-dev  # JSON, for the file formats the library reads (model files, glove descriptions) and the tools
  libcli11-dev        # CLI11, the glovepose tool's command-line parsing (the library headers do not need it)
  libboost-dev        # Boost.Asio (header-only), the tool's device links: serial ports, TCP and UDP
)
# The test suite adds these (tools/test.sh: every test, in two trees, and the cross builds).
test_packages=(
  clang               # tools/test.sh builds and runs the suite with clang as well (warnings are errors in CI)
  doctest-dev         # doctest, the C++ tests' framework (GLOVEPOSE_BUILD_TESTS)
  libbenchmark-dev    # Google Benchmark, the benchmark executables (GLOVEPOSE_BUILD_BENCHMARKS)
  python3-torch       # the PyTorch reference the numerics tests compare with (Debian's, for /usr/bin/python3)
  libopenblas0-pthread  # the BLAS Debian's PyTorch then uses (it links the reference libblas3 otherwise:
                      #   a 1024x1024 float product at 6 GFLOP/s instead of 174 on 2 cores)
  python3-numpy       # the reference checks' arrays, the Python package and the own-glove walkthrough's fit
  mono-mcs            # the C# compiler (and Mono runtime) of the C# package's test (capi_csharp)
  libopenxr-dev       # <openxr/openxr.h>, the OpenXR joint layout's test compares our structs with it
  python3-pip python3-setuptools python3-venv  # `pip install ./python` (the Python package) into a virtual
                      #   environment (Debian's pip refuses the system's Python, PEP 668) without any registry
  ccache              # tools/test.sh and tools/cross.sh compile through it (objects kept between runs)
  liblo-tools         # oscdump, the independent OSC receiver of glovepose serve's test (tests/python/test_serve.py)
  chromium            # the browser test opens glovepose view's page headless (tests/python/test_view.py)
  strace              # record's flush bound, read from its system calls (tests/python/test_wire_stream.py)
)
packages=("${tool_packages[@]}")
[ "$purpose" = all ] && packages+=("${test_packages[@]}")
packages+=("$@")
# glovepose view's page (--view and everything): npm installs the JavaScript it runs (three.js,
# tools/cli/web), embedded at build time (Debian's, unless one is there already, e.g. with
# NodeSource's nodejs, which bundles it).
if [ "$purpose" != demo ]; then
  command -v npm >/dev/null || packages+=(npm)
fi
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
[ "$purpose" = demo ] && exit 0
# The view page's JavaScript from the npm registry, as tools/cli/web/package-lock.json pins it
# (the build embeds it in the tool; nothing is fetched when it runs): again when the lock changed.
web="$(cd "$(dirname "$0")" && pwd)/cli/web"
if [ ! -f "$web/node_modules/.package-lock.json" ] || [ "$web/package-lock.json" -nt "$web/node_modules/.package-lock.json" ]; then
  (cd "$web" && npm ci --no-audit --no-fund --loglevel=error)
fi
