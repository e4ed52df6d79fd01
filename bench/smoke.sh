#!/usr/bin/env bash
# CI's run of one bench/run-*.sh (ctest label `bench`, bench/CMakeLists.txt): tiny sizes, one
# repetition (BENCH_SMOKE=1), on the binaries of the build under test (BUILD_DIR, NO_BUILD=1:
# nothing is compiled twice). Passes when the script exits 0 and its last line is one JSON
# object, as each script promises; exit 77 (ctest: skipped) passes on a script's own skip,
# which names the missing peer tool or fixture. The numbers of a smoke run mean nothing.
#   bench/smoke.sh BUILD_DIR SCRIPT
set -euo pipefail
build_dir=$(cd "${1:?usage: smoke.sh BUILD_DIR SCRIPT}" && pwd)
script=${2:?usage: smoke.sh BUILD_DIR SCRIPT}
cd "$(dirname "$0")/.."
out=$(mktemp)
trap 'rm -f "$out"' EXIT
set +e
BENCH_SMOKE=1 NO_BUILD=1 BUILD_DIR="$build_dir" bash "bench/$script" >"$out"
rc=$?
set -e
if [ $rc -eq 77 ]; then
  echo "smoke: $script skipped (see its message above)"
  exit 77
fi
[ $rc -eq 0 ] || { echo "smoke: $script exited $rc" >&2; tail -5 "$out" >&2; exit 1; }
tail -n 1 "$out" | python3 -c 'import json, sys; j = json.load(sys.stdin); assert isinstance(j, dict), j; print("smoke: ok,", len(j), "keys")' ||
  { echo "smoke: $script's last line is not a JSON object:" >&2; tail -3 "$out" >&2; exit 1; }
