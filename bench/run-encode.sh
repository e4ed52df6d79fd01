#!/usr/bin/env bash
# Builds and runs the encode benchmark (4K RGBA16F -> HDR10 / SDR / scRGB) and prints, as
# its last line, one JSON object:
#   {"hdr10": {...}, "sdr": {...}, "scrgb": {...}}
# each with floor_ms, ocio_ms, hdrd_ms_1t, hdrd_ms_2t, max_code_error, pct_off_by_one
# (medians of the repetitions; floor_ms is the 1-thread floor, floor_ms_2t the 2-thread
# one), plus the ratios the targets are stated in, and for hdr10
# and sdr zimg's times in the same run (zimg_ms_1t/2t, its code error, x_faster_than_zimg_2t).
# env: BUILD_DIR (default build-release), REPS (default 7), NO_BUILD=1 (time the build in
#      BUILD_DIR as it is), BENCH_SMOKE=1 (CI: one repetition, one iteration per case; the
#      numbers mean nothing, the script and the benchmark's names are what is checked)
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${BUILD_DIR:-build-release}
bash bench/build-release.sh "$build_dir" bench_encode
min_time=()
if [ "${BENCH_SMOKE:-0}" = 1 ]; then
  : "${REPS:=1}"
  min_time=(--benchmark_min_time=0.001)
fi
out=$(mktemp)
trap 'rm -f "$out"' EXIT
# Repetitions run in random order across the benchmarks, so a slow spell of the machine
# does not fall on one side of a comparison.
"$build_dir/bench/bench_encode" --benchmark_repetitions="${REPS:-7}" --benchmark_report_aggregates_only=true \
  --benchmark_enable_random_interleaving=true "${min_time[@]}" \
  --benchmark_format=json --benchmark_out="$out" --benchmark_out_format=json >&2
python3 - "$out" <<'PY'
import json, sys
runs = json.load(open(sys.argv[1]))["benchmarks"]
def median(name):
    for r in runs:
        if r["name"] in (name + "_median", name):
            if r.get("aggregate_name", "median") == "median":
                return r["real_time"] if r["time_unit"] == "ms" else r["real_time"] / 1e6
    raise SystemExit("missing " + name)
def counter(name, key):
    for r in runs:
        if r["name"].startswith(name) and key in r:
            return r[key]
    return None
result = {}
for mode in ("hdr10", "sdr", "scrgb"):
    out_bytes = 8 if mode == "scrgb" else 4
    floor = median("BM_floor/%d/1/real_time" % out_bytes)
    floor2 = median("BM_floor/%d/2/real_time" % out_bytes)
    ocio = median("BM_ocio_%s/real_time" % mode)
    t1 = median("BM_hdrd_%s/1/real_time" % mode)
    t2 = median("BM_hdrd_%s/2/real_time" % mode)
    result[mode] = {
        "floor_ms": round(floor, 2), "floor_ms_2t": round(floor2, 2), "ocio_ms": round(ocio, 2),
        "hdrd_ms_1t": round(t1, 2), "hdrd_ms_2t": round(t2, 2),
        "max_code_error": counter("BM_accuracy_" + mode, "max_code_error"),
        "pct_off_by_one": round(counter("BM_accuracy_" + mode, "pct_off_by_one"), 4),
        "x_faster_than_ocio_1t": round(ocio / t1, 1),
        # each thread count against the floor at the same thread count
        "x_of_floor_1t": round(t1 / floor, 2),
        "x_of_floor_2t": round(t2 / floor2, 2),
    }
# zimg (zscale) in its fast mode (approximate gamma), the one the 2-thread target names;
# absent when the benchmark was built without libzimg-dev.
for mode in ("hdr10", "sdr"):
    try:
        z1 = median("BM_zimg_%s/1/1/real_time" % mode)
        z2 = median("BM_zimg_%s/2/1/real_time" % mode)
    except SystemExit:
        continue
    result[mode].update({
        "zimg_ms_1t": round(z1, 2), "zimg_ms_2t": round(z2, 2),
        "zimg_max_code_error": counter("BM_zimg_%s/1/1" % mode, "max_code_error"),
        "zimg_pct_off": round(counter("BM_zimg_%s/1/1" % mode, "pct_off"), 4),
        "x_faster_than_zimg_2t": round(z2 / result[mode]["hdrd_ms_2t"], 2),
    })
ui1 = median("BM_hdrd_hdr10_ui/1/real_time"); ui2 = median("BM_hdrd_hdr10_ui/2/real_time")
result["hdr10"]["hdrd_ui_ms_1t"] = round(ui1, 2)
result["hdr10"]["hdrd_ui_ms_2t"] = round(ui2, 2)
# the UI variant reads and writes the frame's bytes (plus the 1200x300 overlay): same floor
result["hdr10"]["ui_x_faster_than_ocio_1t"] = round(result["hdr10"]["ocio_ms"] / ui1, 1)
result["hdr10"]["ui_x_of_floor_2t"] = round(ui2 / result["hdr10"]["floor_ms_2t"], 2)
print(json.dumps(result))
PY
