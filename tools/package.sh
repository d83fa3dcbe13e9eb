#!/usr/bin/env bash
# Release archives, one per platform, and the C# (Unity) package with its native libraries, with
# SHA-256 checksums:
#   glovepose-VERSION-linux-x64.tar.gz     headers, libglovepose_c.so, libglovepose_eval.so (offline
#                                          evaluation for C and Python), the tool, the shipped models
#   glovepose-VERSION-linux-arm64.tar.gz   the same for 64-bit ARM Linux (glibc)
#   glovepose-VERSION-windows-x64.zip      headers, glovepose_c.dll and glovepose_eval.dll + import
#                                          libraries, glovepose.exe, models
#   com.glovepose.glovepose-VERSION.tgz    bindings/csharp as a Unity package (package/ inside, as npm
#                                          packs it), Windows x64 and Linux x64 glovepose_c under Plugins/
#   SHA256SUMS
# Usage: tools/package.sh [OUT_DIR]   (default: out/packages)
# Builds the Linux x64 release tree (build-release/: baseline x86-64, no -march, no tests) and the
# cross trees (tools/cross.sh windows|arm64, with their tests) unless they are built already.
set -euo pipefail
cd "$(dirname "$0")/.."
out="$(mkdir -p "${1:-out/packages}" && cd "${1:-out/packages}" && pwd)"
stage="$out/stage"
rm -rf "$stage" && mkdir -p "$stage"

# Binaries engines ship run on machines nobody knows: baseline x86-64 (the C ABI is built so in
# every tree; the tool here too), Release, no test or benchmark. Their networks are
# glovepose::compiled's, built per instruction set: each machine runs the best it executes.
cmake -S . -B build-release -DCMAKE_BUILD_TYPE=Release -DGLOVEPOSE_NATIVE=OFF -DGLOVEPOSE_UNITY_BUILD=ON \
  -DGLOVEPOSE_BUILD_TESTS=OFF -DGLOVEPOSE_BUILD_EXAMPLES=OFF -DGLOVEPOSE_BUILD_BENCHMARKS=OFF >/dev/null
cmake --build build-release -j"$(nproc)"
for platform in windows arm64; do
  [ -f "build-$platform/CMakeCache.txt" ] && cmake --build "build-$platform" -j"$(nproc)" >/dev/null || bash tools/cross.sh "$platform"
done
version=$(sed -n 's/^CMAKE_PROJECT_VERSION:STATIC=//p' build-release/CMakeCache.txt)
[ -n "$version" ] || { echo "package: no project version in build-release/CMakeCache.txt" >&2; exit 1; }

# cmake --install of a tree into stage/NAME, then one archive of it.
archive() {  # tree name kind(tar|zip)
  local tree=$1 name=$2 kind=$3
  cmake --install "$tree" --prefix "$stage/$name" >/dev/null
  if [ "$kind" = zip ]; then
    (cd "$stage" && rm -f "$out/$name.zip" && zip -qr "$out/$name.zip" "$name")
  else
    tar -C "$stage" -czf "$out/$name.tar.gz" "$name"
  fi
}
archive build-release "glovepose-$version-linux-x64" tar
archive build-arm64 "glovepose-$version-linux-arm64" tar
archive build-windows "glovepose-$version-windows-x64" zip

# The Unity package: the folder as committed, the libraries where its README says. No Android
# library: that needs the NDK (docs/platforms.md).
unity="$stage/unity/package"
mkdir -p "$unity/Runtime/Plugins/x86_64"
cp -r bindings/csharp/package.json bindings/csharp/README.md bindings/csharp/Runtime "$unity/"
cp "$stage/glovepose-$version-windows-x64/bin/glovepose_c.dll" "$unity/Runtime/Plugins/x86_64/"
cp -L "$stage/glovepose-$version-linux-x64/lib/libglovepose_c.so" "$unity/Runtime/Plugins/x86_64/libglovepose_c.so"
tar -C "$stage/unity" -czf "$out/com.glovepose.glovepose-$version.tgz" package

rm -rf "$stage"
(cd "$out" && sha256sum glovepose-"$version"-* com.glovepose.glovepose-"$version".tgz > SHA256SUMS)
echo "package: $out"
(cd "$out" && ls -l glovepose-"$version"-* com.glovepose.glovepose-"$version".tgz && cat SHA256SUMS)
