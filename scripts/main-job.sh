#!/usr/bin/env bash
# Encodes a fixture EXR to every display mode into ./out (see README).
set -euo pipefail
cd "$(dirname "$0")/.."
hdrd=${BUILD_DIR:-build}/tools/hdrd
out=${OUT_DIR:-out}
mkdir -p "$out"
input=${1:-../shared/fixtures/exr/Desk.exr}
for mode in hdr10 hlg scrgb sdr sdr-bt1886; do
  "$hdrd" encode "$input" -o "$out/desk-$mode" --mode "$mode"
done
ls -l "$out"
