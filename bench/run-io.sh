#!/usr/bin/env bash
# The commands users wait for, whole, against ffmpeg and oiiotool doing the nearest
# equivalent work in the same run (docs/performance.md "Frame I/O"). Builds Release, makes
# 3840x2160 and 1920x1080 half-float ZIP EXRs from ../shared/fixtures/exr/MtTamWest.exr and
# times, for each size:
#   hdrd_hdr10_png   hdrd encode IN -o OUT --mode hdr10 --format png
#   hdrd_sdr_png     hdrd encode IN -o OUT --mode sdr --format png        (8-bit sRGB)
#   hdrd_dump        hdrd encode IN -o OUT --mode hdr10                   (png + exr + raw + json)
#   hdrd_daemon      POST /v1/encode?mode=hdr10 (PNG answer) with curl over the Unix socket
#   ffmpeg_hdr10_png ffmpeg, zscale linear Rec.709 -> Rec.2020 PQ, 16-bit PNG (no tone curve, no metadata)
#   ffmpeg_sdr_png   ffmpeg, tonemap=hable + zscale to sRGB, 8-bit PNG
#   oiiotool_png16   oiiotool IN -d uint16 -o OUT.png   (no transfer function at all)
#   oiiotool_sdr_png oiiotool IN --colorconvert linear sRGB -d uint8 -o OUT.png
#   oiiotool_exr_piz oiiotool IN -d half --compression piz -o OUT.exr   (the dump's EXR writer)
# Every repetition runs every case once, in a new random order; medians of REPS. hdrd's own
# progress lines give read / encode / write of each hdrd command, and bench_io times each
# stage and writer in one process. The daemon's own cost: bench_daemon's
# BM_EncodeOverhead_Interleaved, POST /v1/encode of the file against the same frame job in
# one process, alternated (daemon_overhead; target: within 10 %). Also: process start
# (hdrd encode on a 16x16 EXR).
# The last line is one JSON object with the medians, the breakdowns and the ratios the
# targets are stated in (x_* = the other tool's time / hdrd's).
# env: BUILD_DIR (default build-release), REPS (default 5), SIZES (default "4k 1080p"),
#      NO_BUILD=1 (time the build in BUILD_DIR as it is), BENCH_SMOKE=1 (CI: the 16x16 input,
#      one repetition; a missing peer tool or fixture skips with exit 77 instead of installing)
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${BUILD_DIR:-build-release}
smoke=${BENCH_SMOKE:-0}
if [ "$smoke" = 1 ]; then : "${REPS:=1}" "${SIZES:=tiny}"; fi
bash bench/build-release.sh "$build_dir" hdrd bench_io bench_daemon
build_type=$(sed -n 's/^CMAKE_BUILD_TYPE:STRING=//p' "$build_dir/CMakeCache.txt")

need=()
command -v ffmpeg >/dev/null || need+=(ffmpeg)
command -v oiiotool >/dev/null || need+=(openimageio-tools)
command -v curl >/dev/null || need+=(curl)
if [ ${#need[@]} -gt 0 ] && [ "$smoke" = 1 ]; then
  echo "run-io: skipped: the peers ${need[*]} are missing (apt-get install ${need[*]})" >&2
  exit 77
fi
if [ ${#need[@]} -gt 0 ]; then
  sudo=""; [ "$(id -u)" -ne 0 ] && sudo=sudo
  echo "run-io: installing ${need[*]}" >&2
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${need[@]}" >&2
fi

shared=${HDRD_SHARED_DIR:-../shared}
src="$shared/fixtures/exr/MtTamWest.exr"
[ -f "$src" ] || { echo "run-io: $src missing (set HDRD_SHARED_DIR)" >&2; [ "$smoke" = 1 ] && exit 77; exit 1; }
work="$build_dir/bench-io"
mkdir -p "$work/in"
for spec in 4k:3840x2160 1080p:1920x1080 tiny:16x16; do
  name=${spec%%:*}
  # the tiny input is the process-start case's; the others only when timed
  [ "$name" = tiny ] || [[ " ${SIZES:-4k 1080p} " == *" $name "* ]] || continue
  [ -f "$work/in/$name.exr" ] ||
    oiiotool "$src" --ch R,G,B --resize "${spec#*:}" -d half --compression zip -o "$work/in/$name.exr"
done

exec python3 - "$build_dir" "$work" "${REPS:-5}" "${SIZES:-4k 1080p}" "$build_type" <<'PY'
import json, os, random, re, shutil, signal, socket, statistics, subprocess, sys, time

build, work, reps, sizes, build_type = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4].split(), sys.argv[5]
hdrd = os.path.join(build, "tools", "hdrd")
bench_io = os.path.join(build, "bench", "bench_io")
bench_daemon = os.path.join(build, "bench", "bench_daemon")
out = os.path.join(work, "out")
sock = os.path.join(work, "hdrd.sock")

# The daemon, on its own socket; identical requests would share a job, so never coalesce.
daemon = subprocess.Popen([hdrd, "serve", "--socket", sock, "--no-coalesce", "--log-level", "warn",
                           "--no-socket-activation"], stderr=subprocess.DEVNULL)
def stop_daemon(*_):
    if daemon.poll() is None:
        daemon.send_signal(signal.SIGTERM)
        daemon.wait(timeout=30)
signal.signal(signal.SIGTERM, lambda *a: (stop_daemon(), sys.exit(1)))
for _ in range(300):
    if os.path.exists(sock):
        try:
            socket.socket(socket.AF_UNIX).connect(sock)
            break
        except OSError:
            pass
    time.sleep(0.1)
else:
    stop_daemon()
    raise SystemExit("run-io: the daemon did not start")

ZSCALE_PQ = ("zscale=transferin=linear:primariesin=709:matrixin=gbr:transfer=smpte2084:primaries=2020:"
             "matrix=gbr:npl=203,format=rgb48be")
TONEMAP_SDR = ("format=gbrpf32le,tonemap=tonemap=hable:desat=0,zscale=transferin=linear:primariesin=709:"
               "matrixin=gbr:transfer=iec61966-2-1:primaries=709:matrix=gbr,format=rgb24")

def cases(inp):
    o = lambda n: os.path.join(out, n)
    return {
        "hdrd_hdr10_png": [hdrd, "encode", inp, "-o", o("h"), "--mode", "hdr10", "--format", "png"],
        "hdrd_sdr_png": [hdrd, "encode", inp, "-o", o("s"), "--mode", "sdr", "--format", "png"],
        "hdrd_dump": [hdrd, "encode", inp, "-o", o("d"), "--mode", "hdr10"],
        "hdrd_daemon": ["curl", "-sf", "--unix-socket", sock, "-H", "Content-Type: image/x-exr",
                        "--data-binary", "@" + inp, "http://localhost/v1/encode?mode=hdr10", "-o", o("daemon.png")],
        "ffmpeg_hdr10_png": ["ffmpeg", "-v", "error", "-y", "-i", inp, "-vf", ZSCALE_PQ, "-update", "1", o("f.png")],
        "ffmpeg_sdr_png": ["ffmpeg", "-v", "error", "-y", "-i", inp, "-vf", TONEMAP_SDR, "-update", "1", o("f8.png")],
        "oiiotool_png16": ["oiiotool", inp, "-d", "uint16", "-o", o("o.png")],
        "oiiotool_sdr_png": ["oiiotool", inp, "--colorconvert", "linear", "sRGB", "-d", "uint8", "-o", o("o8.png")],
        "oiiotool_exr_piz": ["oiiotool", inp, "-d", "half", "--compression", "piz", "-o", o("o.exr")],
    }

PROGRESS = {"read": r"read .* in (\d+) ms", "encode": r"encoded .* in (\d+) ms", "write": r"wrote .* in (\d+) ms"}

def run(cmd):
    t0 = time.perf_counter()
    p = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    ms = (time.perf_counter() - t0) * 1e3
    if p.returncode != 0:
        stop_daemon()
        raise SystemExit("run-io: %s failed: %s" % (" ".join(cmd), p.stderr[-500:]))
    parts = {k: float(m.group(1)) for k, rx in PROGRESS.items() if (m := re.search(rx, p.stderr))}
    return ms, parts

def fresh_out():
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)

med = lambda v: round(statistics.median(v), 1)
result = {"reps": reps, "build_type": build_type, "cores": os.cpu_count(), "load_avg_start": os.getloadavg()[0]}
try:
    for size in sizes:
        inp = os.path.join(work, "in", size + ".exr")
        cs = cases(inp)
        times = {k: [] for k in cs}
        parts = {k: {} for k in cs}
        for r in range(reps):
            order = list(cs)
            random.shuffle(order)
            for name in order:
                fresh_out()
                ms, p = run(cs[name])
                times[name].append(ms)
                for k, v in p.items():
                    parts[name].setdefault(k, []).append(v)
        res = {name + "_ms": med(v) for name, v in times.items()}
        res["breakdown_ms"] = {name: {k: med(v) for k, v in p.items()} for name, p in parts.items() if p}
        fresh_out()
        stages = subprocess.run([bench_io, inp, os.path.join(work, "stage"), "--reps", str(reps)],
                                capture_output=True, text=True, check=True)
        res["stages"] = json.loads(stages.stdout.strip().splitlines()[-1])
        x = lambda a, b: round(res[a + "_ms"] / res[b + "_ms"], 2)
        res["x_ffmpeg_hdr10_png"] = x("ffmpeg_hdr10_png", "hdrd_hdr10_png")      # target >= 4
        res["x_ffmpeg_png_vs_dump"] = x("ffmpeg_hdr10_png", "hdrd_dump")         # target >= 2
        res["x_ffmpeg_sdr_png"] = x("ffmpeg_sdr_png", "hdrd_sdr_png")            # target >= 3
        res["x_oiiotool_png16"] = x("oiiotool_png16", "hdrd_hdr10_png")
        res["x_oiiotool_sdr_png"] = x("oiiotool_sdr_png", "hdrd_sdr_png")
        env = dict(os.environ, HDRD_BENCH_EXR=inp, HDRD_BINARY=hdrd)
        bd = subprocess.run([bench_daemon, "--benchmark_filter=EncodeOverhead", "--benchmark_format=json",
                             "--benchmark_repetitions=1"], capture_output=True, text=True, check=True, env=env)
        b = json.loads(bd.stdout)["benchmarks"][0]
        if b.get("error_occurred"):
            raise SystemExit("run-io: bench_daemon: " + b.get("error_message", ""))
        res["daemon_overhead"] = {k: round(b[k], 2) for k in ("inprocess_ms", "daemon_ms", "overhead_ms", "overhead_pct",
                                                              "daemon_encode_ms", "upload_mb")}
        result[size] = res
    tiny = os.path.join(work, "in", "tiny.exr")
    start = {"version": [], "encode_tiny": []}
    for _ in range(reps * 2):
        start["version"].append(run([hdrd, "--version"])[0])
        start["encode_tiny"].append(run([hdrd, "encode", tiny, "-o", os.path.join(out, "t"), "--mode", "hdr10",
                                         "--format", "png"])[0])
    result["process_start_ms"] = {k: med(v) for k, v in start.items()}
    result["targets"] = {size: {"hdr10_png_x4": result[size]["x_ffmpeg_hdr10_png"] >= 4,
                                "dump_x2": result[size]["x_ffmpeg_png_vs_dump"] >= 2,
                                "sdr_png_x3": result[size]["x_ffmpeg_sdr_png"] >= 3,
                                "daemon_within_10pct": result[size]["daemon_overhead"]["overhead_pct"] <= 10} for size in sizes}
finally:
    stop_daemon()
    shutil.rmtree(out, ignore_errors=True)
print(json.dumps(result))
PY
