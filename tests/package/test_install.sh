#!/usr/bin/env bash
# Installs the built library (the "dev" component) into a temporary prefix and
# builds and runs a one-file consumer against it twice: with find_package and
# with pkg-config. No network; a few seconds.
# Usage: [CXX=...] [CONSUMER_CXXFLAGS=...] tests/package/test_install.sh BUILD_DIR SOURCE_ROOT
# (ctest passes the library's compiler and flags, e.g. the sanitizers'.)
set -euo pipefail
build="$(cd "$1" && pwd)"
src="$(cd "$2" && pwd)"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
prefix="$tmp/prefix"
consumer="$src/tests/package/consumer"
expected='grad 2 4 6, icosphere 42 vertices'

cmake --install "$build" --component dev --prefix "$prefix" > "$tmp/install.log"
test -f "$prefix/include/gradraster/autodiff/tensor.h"

# 1. CMake: find_package(gradraster) + gradraster::gradraster.
cmake -S "$consumer" -B "$tmp/cmake-build" -DCMAKE_PREFIX_PATH="$prefix" \
  -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER="${CXX:-c++}" \
  -DCMAKE_CXX_FLAGS="${CONSUMER_CXXFLAGS:-}" > "$tmp/configure.log"
cmake --build "$tmp/cmake-build" > "$tmp/build.log"
out="$("$tmp/cmake-build/consumer")"
[[ "$out" == "$expected" ]] || { echo "find_package consumer printed '$out'" >&2; exit 1; }

# 2. pkg-config: the .pc file found through PKG_CONFIG_PATH, relocated to the prefix.
pc_dir="$(dirname "$(find "$prefix" -name gradraster.pc)")"
flags="$(PKG_CONFIG_PATH="$pc_dir" pkg-config --cflags --libs gradraster)"
# shellcheck disable=SC2086  # the flag lists are meant to split
"${CXX:-c++}" -std=c++17 -O1 ${CONSUMER_CXXFLAGS:-} "$consumer/consumer.cc" -o "$tmp/pc-consumer" $flags
out="$("$tmp/pc-consumer")"
[[ "$out" == "$expected" ]] || { echo "pkg-config consumer printed '$out'" >&2; exit 1; }
echo "installed gradraster builds and runs with find_package and with pkg-config"
