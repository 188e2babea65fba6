#!/usr/bin/env bash
# Installs the built library (the "dev" component) into a temporary prefix and
# builds and runs a one-file consumer against it twice: with find_package and
# with pkg-config; with the Python module built, installs the "python"
# component too and imports gradraster.torch from there. First the installed CMake package and .pc file must carry no
# flag of the build machine (check_package_flags.sh), and that check must
# reject a copy with -march=native put back. No network; a few seconds.
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
test -f "$prefix/include/gradraster/autodiff/base/tensor.h"

# Only public headers (cmake/public_headers.cmake): internal helpers stay out,
# and what is installed compiles with nothing but the installed tree.
include_dir="$prefix/include/gradraster"
for internal in raster/detail/rasterize_scan.h raster/io/png_encoder.h ops/mesh/row_sums.h ops/shading/arguments.h ops/check.h; do
  [[ -f "$src/$internal" ]] || { echo "test_install.sh: $internal is no longer in the source tree; name another internal header" >&2; exit 1; }
  [[ ! -e "$include_dir/$internal" ]] || { echo "internal header $internal was installed" >&2; exit 1; }
done
(cd "$include_dir" && find . -name '*.h' | sort | sed 's|^\./\(.*\)$|#include "\1"|') > "$tmp/all_headers.cc"
"${CXX:-c++}" -std=c++17 -fsyntax-only ${CONSUMER_CXXFLAGS:-} \
  -I "$include_dir" "$tmp/all_headers.cc" ||
  { echo "the installed headers do not compile on their own (a public header includes one not installed?)" >&2; exit 1; }

# 0. What the package asks of consumers: nothing of this machine, no Eigen,
# -ffp-contract=off on both routes. The check itself must catch a leak.
"$src/tests/package/check_package_flags.sh" "$prefix"
leaky="$tmp/leaky"
rejects_leak() {  # FILE: check_package_flags.sh must reject the copy, for its machine flags
  if "$src/tests/package/check_package_flags.sh" "$leaky" 2> "$tmp/leak.err" ||
     ! grep -q "build machine's flags" "$tmp/leak.err"; then
    echo "check_package_flags.sh did not reject a $1 with -march=native:" >&2
    cat "$tmp/leak.err" >&2
    exit 1
  fi
}
cp -r "$prefix" "$leaky"
sed -i 's/-ffp-contract=off/-ffp-contract=off;-march=native;-mno-avx512f/' "$leaky"/lib*/cmake/gradraster/gradrasterTargets.cmake
rejects_leak gradrasterTargets.cmake
cp -r "$prefix/." "$leaky"
sed -i 's/^Cflags: \(.*\)$/Cflags: \1 -march=native/' "$leaky"/lib*/pkgconfig/gradraster.pc
rejects_leak gradraster.pc

# 1. CMake: find_package(gradraster) + gradraster::gradraster.
cmake -S "$consumer" -B "$tmp/cmake-build" -DCMAKE_PREFIX_PATH="$prefix" \
  -DCMAKE_BUILD_TYPE=Release -DCMAKE_EXPORT_COMPILE_COMMANDS=ON -DCMAKE_CXX_COMPILER="${CXX:-c++}" \
  -DCMAKE_CXX_FLAGS="${CONSUMER_CXXFLAGS:-}" > "$tmp/configure.log"
cmake --build "$tmp/cmake-build" > "$tmp/build.log"
# The consumer's compile line has the package's requirement, not the build's
# machine flags (CONSUMER_CXXFLAGS are this test's own, e.g. the sanitizers').
command="$(grep '"command"' "$tmp/cmake-build/compile_commands.json")"
[[ "$command" == *-ffp-contract=off* ]] || { echo "find_package consumer compiled without -ffp-contract=off: $command" >&2; exit 1; }
if [[ "$command" == *-march=* && "${CONSUMER_CXXFLAGS:-}" != *-march=* ]]; then
  echo "find_package consumer compiled with the library's -march: $command" >&2; exit 1
fi
out="$("$tmp/cmake-build/consumer")"
[[ "$out" == "$expected" ]] || { echo "find_package consumer printed '$out'" >&2; exit 1; }

# 2. pkg-config: the .pc file found through PKG_CONFIG_PATH, relocated to the prefix.
pc_dir="$(dirname "$(find "$prefix" -name gradraster.pc)")"
flags="$(PKG_CONFIG_PATH="$pc_dir" pkg-config --cflags --libs gradraster)"
[[ "$flags" == *-ffp-contract=off* ]] || { echo "pkg-config gives no -ffp-contract=off: $flags" >&2; exit 1; }
[[ "$flags" != *-march=* ]] || { echo "pkg-config gives a -march flag: $flags" >&2; exit 1; }
# stb_image is compiled into the library from libstb-dev's header: no consumer links libstb.
if [[ "$flags" == *-lstb* ]] || grep -qi "stb" "$(dirname "$pc_dir")"/cmake/gradraster/*.cmake; then
  echo "the package asks for libstb (pkg-config: $flags)" >&2; exit 1
fi
# shellcheck disable=SC2086  # the flag lists are meant to split
"${CXX:-c++}" -std=c++17 -O1 ${CONSUMER_CXXFLAGS:-} "$consumer/consumer.cc" -o "$tmp/pc-consumer" $flags
out="$("$tmp/pc-consumer")"
[[ "$out" == "$expected" ]] || { echo "pkg-config consumer printed '$out'" >&2; exit 1; }
echo "installed gradraster builds and runs with find_package and with pkg-config"

# 3. Python, when the build has the module (ctest then sets GRADRASTER_PYTHON,
# its interpreter, GRADRASTER_VERSION and GRADRASTER_HAS_VULKAN): the "python"
# component, imported from another folder with PYTHONPATH=<prefix>/lib/pythonX.Y/site-packages
# (docs/python.md). GRADRASTER_PYTHON_PRELOAD: the ASan runtime of a sanitizer build.
if [[ -n "${GRADRASTER_PYTHON:-}" ]]; then
  cmake --install "$build" --component python --prefix "$prefix" > "$tmp/install-python.log"
  site="$prefix/lib/python$("$GRADRASTER_PYTHON" -c 'import sys; print("%d.%d" % sys.version_info[:2])')/site-packages"
  [[ -f "$site/gradraster/torch/__init__.py" ]] || { echo "cmake --install put no gradraster package in $site" >&2; exit 1; }
  python_env=(PYTHONPATH="$site")
  if [[ -n "${GRADRASTER_PYTHON_PRELOAD:-}" ]]; then
    python_env+=(LD_PRELOAD="$GRADRASTER_PYTHON_PRELOAD" ASAN_OPTIONS=detect_leaks=0)
  fi
  (cd "$tmp" && env "${python_env[@]}" "$GRADRASTER_PYTHON" "$src/tests/package/check_python_package.py" \
     "$prefix" "$GRADRASTER_VERSION" "$GRADRASTER_HAS_VULKAN")
fi
