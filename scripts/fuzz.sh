#!/usr/bin/env bash
# Builds the libFuzzer targets with clang-14 (ASan + UBSan, coverage in every hdrd library)
# and fuzzes each for a while, starting from its checked-in corpus (tests/fuzz/corpus/NAME; exr_fuzz: ../shared/fixtures/exr;
# new inputs go to a scratch copy, not into the repository). Crashes are left as
# crash-* files in $BUILD_DIR/fuzz-out/NAME.
#
# Usage: scripts/fuzz.sh [-t SECONDS_PER_TARGET] [TARGET...]
#   targets: edid_fuzz exr_fuzz png_fuzz cube_fuzz gltf_fuzz scene_json_fuzz request_fuzz query_fuzz multipart_fuzz
#            slurm_fuzz avif_boxes_fuzz radiance_hdr_fuzz video_bitstream_fuzz log_escape_fuzz beneath_fuzz (default: all)
# env: BUILD_DIR (default build-fuzz), JOBS, PARALLEL (targets fuzzed at once, default 1), FUZZ_TIMEOUT (seconds one input may take, default 10;
#      raise it on a shared machine where the fuzzer can be starved of CPU: a starved unit
#      is reported as a timeout although it runs in milliseconds, and ends the run)
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=60
while getopts "t:h" opt; do
  case $opt in
    t) seconds=$OPTARG ;;
    *) sed -n '2,11p' "$0"; exit 2 ;;
  esac
done
shift $((OPTIND - 1))
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(edid_fuzz exr_fuzz png_fuzz cube_fuzz gltf_fuzz scene_json_fuzz request_fuzz query_fuzz multipart_fuzz
                                    slurm_fuzz avif_boxes_fuzz radiance_hdr_fuzz video_bitstream_fuzz log_escape_fuzz beneath_fuzz)
build_dir=${BUILD_DIR:-build-fuzz}
command -v clang++-14 >/dev/null || { echo "fuzz: clang++-14 is missing (scripts/install-deps.sh installs it)" >&2; exit 2; }
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DHDRD_FUZZ=ON -DHDRD_BUILD_BENCH=OFF >/dev/null
cmake --build "$build_dir" -j "${JOBS:-$(nproc)}" --target "${targets[@]}"
# One target's run; its verdict is the exit status.
fuzz_one() {
  local t=$1 bin out runs cov
  bin=$(find "$build_dir" -type f -name "$t" -perm -u+x | head -n1)
  out="$build_dir/fuzz-out/$t"
  mkdir -p "$out/corpus"
  cp -r tests/fuzz/corpus/"$t"/. "$out/corpus/" 2>/dev/null || true
  if [ "$t" = exr_fuzz ]; then cp ../shared/fixtures/exr/*.exr "$out/corpus/" 2>/dev/null || true; fi
  rm -f "$out/failed"
  echo "fuzz: $t for ${seconds}s" >&2
  if ! (cd "$out" && "$root/$bin" -max_total_time="$seconds" -timeout="${FUZZ_TIMEOUT:-10}" -rss_limit_mb=2048 -print_final_stats=1 corpus >log.txt 2>&1); then
    echo "fuzz: $t FAILED, see $out/log.txt and $out/crash-*" >&2
    touch "$out/failed"
    return 1
  fi
  # The run's figures: executions, and the last status line's coverage (cov: edges,
  # ft: features, corp: corpus entries/size).
  runs=$(grep -o 'stat::number_of_executed_units: [0-9]*' "$out/log.txt" | tail -1 | grep -o '[0-9]*$' || true)
  cov=$(grep -o 'cov: [0-9]* ft: [0-9]* corp: [0-9]*/[0-9]*[a-zA-Z]*' "$out/log.txt" | tail -1 || true)
  echo "fuzz: $t clean (runs: ${runs:-?}, ${cov:-no coverage line})" >&2
}
root=$PWD
for t in "${targets[@]}"; do
  fuzz_one "$t" &
  # At most PARALLEL targets at once.
  while [ "$(jobs -rp | wc -l)" -ge "${PARALLEL:-1}" ]; do wait -n || true; done
done
wait
status=0
for t in "${targets[@]}"; do [ ! -e "$build_dir/fuzz-out/$t/failed" ] || status=1; done
exit $status
