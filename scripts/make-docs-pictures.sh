#!/bin/sh
# Regenerates the pictures in docs/img/ (linked from README.md, docs/patterns.md and
# docs/display-modes.md) with the built hdrd. Usage:
#   scripts/make-docs-pictures.sh [path/to/hdrd]     (default: build/tools/hdrd)
# Needs ../shared/fixtures/exr for the contact sheet and heatmap (skipped without it).
set -eu
here=$(cd "$(dirname "$0")/.." && pwd)
hdrd=${1:-$here/build/tools/hdrd}
img=$here/docs/img
shared=${HDRD_SHARED_DIR:-$here/../shared}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$img"

"$hdrd" plot curves --peak 1000 -o "$img/tone-curves-1000.svg" -q
"$hdrd" plot curves --peak 1000 -o "$img/tone-curves-1000.png" -q
"$hdrd" plot fresnel -o "$img/fresnel-metals.svg" -q
"$hdrd" plot fresnel -o "$img/fresnel-metals.png" -q
# Patterns: the PNG dumps are 16-bit PQ/HLG files with cICP (HDR-aware viewers show them right).
"$hdrd" pattern bt2111 --mode hdr10 --width 480 --height 270 --format png -o "$tmp/bars-pq" -q
cp "$tmp/bars-pq.png" "$img/bt2111-pq.png"
"$hdrd" pattern pq-ramp --mode hdr10 --peak 10000 --width 880 --height 120 --format png -o "$tmp/ramp" -q
cp "$tmp/ramp.png" "$img/pq-ramp.png"
"$hdrd" pattern clipping --mode hdr10 --peak 1000 --width 720 --height 160 --format png -o "$tmp/clip" -q
cp "$tmp/clip.png" "$img/clipping-1000.png"
if [ -f "$shared/fixtures/exr/Desk.exr" ]; then
  # Photographic tiles compress poorly: 1/5 of Desk.exr's 644 pixels, five to a row, keeps
  # the sheet under 1 MB with every label readable. At -2 EV the window's highlights show
  # how the curves differ and the room stays readable.
  "$hdrd" contact-sheet "$shared/fixtures/exr/Desk.exr" -o "$img/contact-sheet-desk.png" --tile-width 130 \
    --columns 5 --exposure -2 -q
  # The heatmap output of an HDR10 encode (`--format heatmap`).
  "$hdrd" encode "$shared/fixtures/exr/Desk.exr" --mode hdr10 --peak 1000 --format heatmap -o "$tmp/desk" -q
  cp "$tmp/desk.heatmap.png" "$img/heatmap-desk.png"
else
  echo "make-docs-pictures: $shared/fixtures/exr/Desk.exr missing: contact sheet and heatmap skipped" >&2
fi
if [ -f "$shared/fixtures/exr/WideColorGamut.exr" ]; then
  # The gamut-mapping family side by side: a wide-gamut chromaticity sweep into Rec.709.
  "$hdrd" contact-sheet "$shared/fixtures/exr/WideColorGamut.exr" -o "$img/gamut-maps-wide.png" --layout gamut-maps \
    --tile-width 240 --columns 3 -q
fi
# Environment light: material-grid under its Preetham sky and under a studio EXR, SDR and
# the heatmap of the HDR10 display luminance. bench_render_pictures renders them through
# the library (it writes the studio map too); with `hdrd render --environment` wired, the
# same pictures are `hdrd render --scene material-grid [--environment studio.exr]
# --mode sdr` and `--mode hdr10 --debug heatmap`.
pictures=${HDRD_PICTURES:-$here/build/bench/bench_render_pictures}
if [ -x "$pictures" ]; then
  "$pictures" "$tmp/env"
  for name in material-grid-sky material-grid-studio; do
    cp "$tmp/env/$name-sdr.png" "$tmp/env/$name-hdr10-heatmap.png" "$img/"
  done
else
  echo "make-docs-pictures: $pictures not built (ninja bench_render_pictures): environment pictures skipped" >&2
fi
# Each built-in scene's default frame (docs/rendering.md, "Default frames"), 480x270, SDR and
# the heatmap of its HDR10 display light, before and after renders metered their picture:
# "before" is `--exposure-mode light` (the old default: white card under the dominant
# light = 1.0), "after" the defaults. Prints each HDR10 sidecar's frame average and
# percentiles (frame_light) as the table rows the doc shows.
scenes=$("$hdrd" render --help | sed -n 's/.*A built-in scene (\([^)]*\)).*/\1/p' | tr -d ,)
echo "| scene | exposure | mode, EV100 of its scale | frame average | 1 % | 10 % | 25 % | 50 % | 75 % | 90 % | 99 % | max |"
for scene in $scenes; do
  for when in before after; do
    set -- --scene "$scene" --width 480 --height 270 -q
    [ "$when" = before ] && set -- "$@" --exposure-mode light
    "$hdrd" render "$@" --mode sdr --format png -o "$tmp/$scene-$when-sdr"
    cp "$tmp/$scene-$when-sdr.png" "$img/scene-$scene-$when-sdr.png"
    "$hdrd" render "$@" --mode hdr10 --format heatmap -o "$tmp/$scene-$when-hdr10"
    cp "$tmp/$scene-$when-hdr10.heatmap.png" "$img/scene-$scene-$when-hdr10-heatmap.png"
    jq -r --arg s "$scene" --arg w "$when" '.frame_light as $l | .settings.exposure as $e |
      "| `\($s)` | \($w) | \($e.mode), EV100 \(1 / (1.2 * $e.scale) | log2 | . * 10 | round / 10) | \($l.frame_average_nits | . * 100 | round / 100) | " +
      ([$l.percentiles_nits["1","10","25","50","75","90","99"]] | map(. * 100 | round / 100 | tostring) | join(" | ")) +
      " | \($l.max_nits | round) |"' "$tmp/$scene-$when-hdr10.json"
  done
done
ls -l "$img"
