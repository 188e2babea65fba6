#!/usr/bin/env bash
# The README's first command: installs what is missing and builds (through
# scripts/setup.sh), then runs the main example, gradraster-fit, with its
# defaults (or with the flags given here, e.g. --mode pose, --fit texture,
# --mesh my.obj --texture my.png, --out my_out; see --help), and says where its
# pictures are.
set -euo pipefail
cd "$(dirname "$0")/.."

scripts/setup.sh
build_dir=${GRADRASTER_BUILD_DIR:-build}
"$build_dir/examples/fit/gradraster-fit" "$@"

# Report the output folder the example used (its --out flag, default out/).
out=out
args=("$@")
for ((i = 0; i < ${#args[@]}; i++)); do
  case "${args[i]}" in
    --out) out=${args[i + 1]:-out} ;;
    --out=*) out=${args[i]#--out=} ;;
    --help | -h) exit 0 ;;
  esac
done
echo
echo "demo: outputs in $(cd "$out" && pwd)/"
echo "  snapshot_NNNN.png  target | current | |difference| per view, at the start, during the run and at the end"
echo "  loss.png           image loss per iteration (log scale)"
echo "  fitted.obj         the fitted mesh (--mode pose: posed.obj; --fit texture: + fitted.mtl, fitted_texture.png)"
