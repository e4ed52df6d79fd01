#!/usr/bin/env bash
# Installs the Debian 12 packages hdrd builds, tests and runs with; only what is missing.
# Safe to run repeatedly. Needs root (or sudo) only when something is missing.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git curl python3
  libopenexr-dev libimath-dev libopencolorio-dev opencolorio-tools
  libpng-dev zlib1g-dev libisal-dev libxxhash-dev
  libegl-dev libgl-dev libosmesa6-dev libgl1-mesa-dri libegl-mesa0
  libdrm-dev
  nlohmann-json3-dev libcli11-dev libspdlog-dev libfmt-dev libtinygltf-dev libstb-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libmicrohttpd-dev libtomlplusplus-dev libhwy-dev libzimg-dev
  clang-14 libclang-rt-14-dev
  edid-decode
  libavcodec-dev libavformat-dev libavutil-dev
  libavif-dev libjxl-dev libjpeg62-turbo-dev
  # decoders the tests read the files back with (they skip without them)
  libavif-bin libheif-examples libjxl-tools libjpeg-turbo-progs ffmpeg libimage-exiftool-perl
  # the benchmarks' peer and input maker (bench/run-io.sh, bench/make-pans.sh; their CI smoke
  # runs skip without it)
  openimageio-tools
)

# shellcheck source=scripts/lib/apt-missing.sh
source "$(dirname "${BASH_SOURCE[0]}")/lib/apt-missing.sh"
apt_install_missing install-deps "${packages[@]}"
