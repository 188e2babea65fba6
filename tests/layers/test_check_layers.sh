#!/usr/bin/env bash
# scripts/check_layers.sh fails, naming the file, when a raster/ or base file
# includes a tape-side header; and passes on a copy of the real tree.
# Usage: tests/layers/test_check_layers.sh SOURCE_ROOT
set -euo pipefail
src="$1"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

cp -r "$src/raster" "$src/autodiff" "$tmp/"
"$src/scripts/check_layers.sh" "$tmp" > /dev/null || fail "the unchanged tree should pass"

for bad in autodiff/tape.h autodiff/gradcheck.h autodiff/optim.h autodiff/accumulate.h ops/ops.h ops/render/rasterize.h; do
  for file in raster/rasterize.cpp raster/texture.h raster/io/image_io.cpp raster/detail/rasterize_scan.cpp autodiff/base/tensor.cpp; do
    cp "$src/$file" "$tmp/$file"
    printf '#include "%s"\n' "$bad" >> "$tmp/$file"
    if "$src/scripts/check_layers.sh" "$tmp" 2> "$tmp/err.txt" > /dev/null; then
      fail "$file including $bad passed the check"
    fi
    grep -q "$file:.* includes $bad" "$tmp/err.txt" || fail "message does not name $file and $bad: $(cat "$tmp/err.txt")"
    cp "$src/$file" "$tmp/$file"
  done
done
echo "check_layers.sh rejects every tape-side include in raster/ and the base"
