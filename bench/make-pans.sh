#!/usr/bin/env bash
# The panning EXR sequences the sequence benchmarks read (bench/run-sequence.sh,
# bench/run-shards.sh): crops of a 1.25x enlargement of ../shared/fixtures/exr/MtTamWest.exr
# moving right by width/100 per frame, half float, ZIP; a different picture every frame, as a
# camera pan. Made once with oiiotool (Debian's openimageio-tools) into DIR/{1080p,4k,small},
# or only the named sets (tiny: 64x32, 8 frames, for the CI smoke runs).
#   bench/make-pans.sh DIR [SET...]
# Exit status 77 (skip) when oiiotool or the fixture is missing.
set -euo pipefail
cd "$(dirname "$0")/.."
work=${1:?usage: make-pans.sh DIR [SET...]}
shift
sets=("$@")
[ ${#sets[@]} -gt 0 ] || sets=(1080p 4k small)
command -v oiiotool >/dev/null || { echo "make-pans: oiiotool missing (apt-get install openimageio-tools)" >&2; exit 77; }
shared=${HDRD_SHARED_DIR:-../shared}
src="$shared/fixtures/exr/MtTamWest.exr"
[ -f "$src" ] || { echo "make-pans: $src missing (set HDRD_SHARED_DIR)" >&2; exit 77; }
mkdir -p "$work"
# pan NAME W H FRAMES: crops of a 1.25x enlargement, moving right by W/100 per frame.
pan() {
  local name=$1 w=$2 h=$3 n=$4 dir="$work/$1"
  [ -f "$dir/pan.$(printf %03d $((n - 1))).exr" ] && return
  mkdir -p "$dir"
  local bw=$((w * 5 / 4)) bh=$((h * 5 / 4))
  oiiotool "$src" --ch R,G,B --resize "${bw}x${bh}" -d half -o "$dir/big.exr"
  for ((i = 0; i < n; ++i)); do
    oiiotool "$dir/big.exr" --cut "${w}x${h}+$((i * w / 100))+$((h / 8))" -d half --compression zip \
      -o "$dir/pan.$(printf %03d "$i").exr"
  done
}
for s in "${sets[@]}"; do
  case $s in
    1080p) pan 1080p 1920 1080 24 ;;
    4k) pan 4k 3840 2160 12 ;;
    small) pan small 640 360 100 ;;
    tiny) pan tiny 64 32 8 ;;  # not narrower: libx265 3.5 misbehaves under 64 px (tests/daemon/sequences_test.cpp)
    *) echo "make-pans: unknown set $s (1080p, 4k, small, tiny)" >&2; exit 2 ;;
  esac
done
