#!/usr/bin/env bash
# pip's route (docs/python.md, "Installing"), as a user runs it, from a fresh
# copy of the source (the files a clone of this working tree has, no build
# folders): a venv made with --system-site-packages (so Debian's torch and
# numpy), `pip install --no-build-isolation .`, then `import gradraster.torch`
# from another folder. Then `pip wheel` (reusing pip's CMake build) and that
# wheel installed into a second venv. Checks that pip's build left the
# source's build/ alone and nothing in python/, and that a wheel is portable
# (GRADRASTER_NATIVE off) by default. No network. Build jobs:
# CMAKE_BUILD_PARALLEL_LEVEL (ctest sets 1). Cold, 2.5 CPU-minutes (about
# 1.5 minutes on 2 idle cores); 30 s when ccache has the objects.
# Usage: tests/package/test_pip_install.sh SOURCE_ROOT PYTHON VERSION VULKAN(ON|OFF)
set -euo pipefail
src="$(cd "$1" && pwd)"
python="$2" version="$3" vulkan="$4"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
unset PYTHONPATH  # the import must find the installed package, not a build tree
fail() { echo "FAIL: $*" >&2; exit 1; }

# The source: tracked and untracked-but-not-ignored files, as they are now.
copy="$tmp/src"
mkdir "$copy"
if git -C "$src" rev-parse --is-inside-work-tree > /dev/null 2>&1; then
  git -C "$src" ls-files -z --cached --others --exclude-standard |
    while IFS= read -r -d '' f; do [[ -e "$src/$f" ]] && printf '%s\0' "$f"; done |
    tar -C "$src" --null -T - -cf - | tar -C "$copy" -xf -
else
  tar -C "$src" --exclude='./build*' --exclude=./out -cf - . | tar -C "$copy" -xf -
fi
# A user's CMake build folder, which pip's build must not touch.
mkdir "$copy/build"
echo "the user's" > "$copy/build/CMakeCache.txt"

# ccache (setup.py's launcher when installed) shares objects between runs of
# this test: the paths below the temporary folder are the same each time.
export CCACHE_BASEDIR="$tmp"
start=$(date +%s)
"$python" -m venv --system-site-packages "$tmp/v"
(cd "$copy" && "$tmp/v/bin/pip" install --no-build-isolation . > "$tmp/pip-install.log" 2>&1) ||
  { cat "$tmp/pip-install.log" >&2; fail "pip install --no-build-isolation . failed (log above)"; }
echo "pip install: $(( $(date +%s) - start )) s"
mkdir "$tmp/elsewhere"
cd "$tmp/elsewhere"
"$tmp/v/bin/python" -c "import gradraster.torch"
"$tmp/v/bin/python" "$src/tests/package/check_python_package.py" "$tmp/v" "$version" "$vulkan" --dist

[[ "$(ls -A "$copy/build")" == CMakeCache.txt && "$(cat "$copy/build/CMakeCache.txt")" == "the user's" ]] ||
  fail "pip's build changed the source's build/: $(ls -A "$copy/build")"
leftovers="$(cd "$copy" && find python -newer "$copy/build/CMakeCache.txt" ! -type d)"
[[ -z "$leftovers" ]] || fail "pip's build wrote into python/: $leftovers"
grep -qx 'GRADRASTER_NATIVE:BOOL=OFF' "$copy"/build-pip/temp.*/cmake/CMakeCache.txt ||
  fail "pip's build is not portable by default (GRADRASTER_NATIVE is not OFF)"

# A wheel to copy elsewhere, installed into another venv.
start=$(date +%s)
(cd "$copy" && "$tmp/v/bin/pip" wheel --no-build-isolation --no-deps -w "$tmp/wheels" . > "$tmp/pip-wheel.log" 2>&1) ||
  { cat "$tmp/pip-wheel.log" >&2; fail "pip wheel --no-build-isolation . failed (log above)"; }
"$python" -m venv --system-site-packages "$tmp/w"
"$tmp/w/bin/pip" install --no-index "$tmp"/wheels/gradraster-"$version"-*.whl > "$tmp/wheel-install.log" 2>&1 ||
  { cat "$tmp/wheel-install.log" >&2; fail "installing the wheel failed (log above)"; }
echo "pip wheel + install: $(( $(date +%s) - start )) s"
"$tmp/w/bin/python" "$src/tests/package/check_python_package.py" "$tmp/w" "$version" "$vulkan" --dist
echo "pip install . and pip wheel . give an importable gradraster.torch"
