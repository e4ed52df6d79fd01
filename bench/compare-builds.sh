#!/usr/bin/env bash
# Times the encoder of git revisions against each other in one process (bench/pair_encode):
# builds each revision's hdrd_encode in Release as a shared library and alternates them
# frame by frame on bench_encode's 4K HDR10 frame. The first revision is the baseline.
#
#   bench/compare-builds.sh [--threads N] [--rounds N] [--ui] REV [REV ...]
#
# REV is anything git names (a commit, a branch, HEAD~3) or WORKTREE for the files as they
# are now. Each revision's public encode headers (encode/pipeline.hpp and what it includes)
# must match the working tree's, since the frame and settings cross between the builds.
# Example: bench/compare-builds.sh --threads 2 HEAD~1 WORKTREE
set -euo pipefail
cd "$(dirname "$0")/.."
args=()
revs=()
while [ $# -gt 0 ]; do
  case "$1" in
    --threads|--rounds) args+=("$1" "$2"); shift 2 ;;
    --ui) args+=("$1"); shift ;;
    -h|--help) sed -n '2,11p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) revs+=("$1"); shift ;;
  esac
done
if [ ${#revs[@]} -lt 2 ]; then echo "compare-builds.sh: give at least two revisions (see --help)" >&2; exit 2; fi

out=build-compare
mkdir -p "$out"
bash bench/build-release.sh build-release pair_encode hdrd_encode
public_headers=$(g++ -std=c++20 -I. -MM -x c++ - <<<'#include "encode/pipeline.hpp"' | tr ' \\' '\n\n' | grep '^encode/' | sort -u)
libs=()
for rev in "${revs[@]}"; do
  if [ "$rev" = WORKTREE ]; then
    name=worktree
    src=.
    bdir=build-release
  else
    sha=$(git rev-parse --verify --quiet "$rev^{commit}") || { echo "compare-builds.sh: no revision $rev" >&2; exit 2; }
    # shellcheck disable=SC2086
    if ! git diff --quiet "$sha" -- $public_headers; then
      echo "compare-builds.sh: $rev changes the public encode headers; its build cannot share frames with this one" >&2
      exit 2
    fi
    name=$(git rev-parse --short "$sha")
    src=$out/src-$name
    [ -d "$src" ] || git worktree add --detach -f "$src" "$sha" >/dev/null 2>&1
    bdir=$out/build-$name
    generator=(); if command -v ninja >/dev/null 2>&1; then generator=(-G Ninja); fi
    cmake -S "$src" -B "$bdir" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release -DHDRD_BUILD_TESTS=OFF >/dev/null
  fi
  echo "building $rev ($name)" >&2
  cmake --build "$bdir" --target hdrd_encode >/dev/null
  # The static library is position-independent: link all of it, with its dependencies, into one .so.
  g++ -shared -o "$out/$name.so" -Wl,--whole-archive "$bdir/encode/libhdrd_encode.a" -Wl,--no-whole-archive \
    -Wl,-Bsymbolic $(pkg-config --libs libhwy OpenColorIO OpenEXR libpng fmt) -pthread
  libs+=("$out/$name.so")
done
build-release/bench/pair_encode "${args[@]}" "${libs[@]}"
