#!/usr/bin/env bash
# The main job (README): render the default built-in scene and encode a fixture EXR for
# every display mode, into ./out. Each dump is OUTBASE.{png,exr,raw} + OUTBASE.json.
set -euo pipefail
cd "$(dirname "$0")/.."
hdrd=${BUILD_DIR:-build}/tools/hdrd
out=${OUT_DIR:-out}
mkdir -p "$out"
input=${1:-../shared/fixtures/exr/Desk.exr}
modes=(hdr10 hlg scrgb sdr sdr-bt1886)

echo "== render: built-in scene '$("$hdrd" render --help >/dev/null && echo material-grid)' (llvmpipe works headless)" >&2
for mode in "${modes[@]}"; do
  "$hdrd" render -o "$out/scene-$mode" --mode "$mode" --width 960 --height 540
done
if [ -f "$input" ]; then
  echo "== encode: $input" >&2
  for mode in "${modes[@]}"; do
    "$hdrd" encode "$input" -o "$out/exr-$mode" --mode "$mode"
  done
else
  echo "(skipping the EXR encode: $input not found)" >&2
fi
echo "== outputs in $out/" >&2
ls -1 "$out"
