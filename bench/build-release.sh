#!/usr/bin/env bash
# The Release build the bench/run-*.sh scripts time: only the targets they name, with
# ccache when there is one; JOBS as scripts/build.sh. NO_BUILD=1 leaves BUILD_DIR as it is
# (the scripts print its build type with their numbers), after checking that it holds the
# named programs.
#   bench/build-release.sh BUILD_DIR TARGET...
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${1:?usage: build-release.sh BUILD_DIR TARGET...}
shift
if [ "${NO_BUILD:-0}" = 1 ]; then
  # The tree must already hold the programs the caller is about to run.
  for t in "$@"; do
    case $t in
      hdrd) f=tools/hdrd ;;
      bench_* | pair_encode) f=bench/$t ;;
      *) continue ;;
    esac
    [ -x "$build_dir/$f" ] || { echo "build-release: NO_BUILD=1, but $build_dir has no $f (build the target $t first)" >&2; exit 1; }
  done
  exit 0
fi
bash scripts/install-deps.sh >/dev/null
launcher=(); command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release -DHDRD_BUILD_TESTS=OFF "${launcher[@]}" >/dev/null
ninja -C "$build_dir" -j "${JOBS:-$(nproc)}" "$@" >/dev/null
