#!/usr/bin/env bash
# Sequences, whole commands (docs/sequences.md "Performance"). Builds Release, makes panning
# EXR sequences from ../shared/fixtures/exr/MtTamWest.exr with oiiotool (1080p and 4K, a
# different picture every frame, as a camera pan), and measures:
#   split     per-frame time of `hdrd encode 'pan.%03d.exr' --video hevc` by stage, from the
#             sequence sidecar's timings_ms: read, meter+encode, Y'CbCr conversion, metadata,
#             the video encoder's calls, the mux (wall), the CPU of hdrd's own stages
#             (*_cpu: CpuMeter, which leaves out the encoder's threads), and the process CPU
#   own       the same command without video (--format raw into a scratch dir); the video
#             encoder's CPU is the difference. Target: hdrd's own per-frame work outside
#             rendering and the encoder (meter + encode + Y'CbCr + metadata, CPU)
#             <= 10 % of the encoder's CPU at its default preset. Where perf can sample,
#             also the encoder's CPU as its library's share of perf's samples of one video
#             run (the difference also charges it with what it costs the other stages)
#   render    `hdrd render --scene hdr --frames N --video hevc` at 1080p: render per frame
#   rss       resident memory of `hdrd encode` over 300 frames (640x360, --video hevc),
#             sampled every 50 ms: the medians of the run's second and last sixths (after
#             the encoder's warm-up) and the peak, and the peak of a 30-frame run (flat: RSS
#             does not grow with frames)
# Alternated (the video / no-video runs in a new random order each repetition), medians of
# REPS. The last line is one JSON object.
# env: BUILD_DIR (default build-release), REPS (default 3), SIZES (default "1080p 4k"),
#      NO_BUILD=1 (time the build in BUILD_DIR as it is), BENCH_SMOKE=1 (CI: the 64x32 pan,
#      one repetition, a 2-frame 64x32 render, RSS over 12 and 4 frames; skips with exit 77
#      without oiiotool or the fixture). Also RENDER ("WxHxFRAMES", default 1920x1080x4),
#      RSS_SET (default small) and RSS_FRAMES (default "300 30").
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${BUILD_DIR:-build-release}
if [ "${BENCH_SMOKE:-0}" = 1 ]; then
  : "${REPS:=1}" "${SIZES:=tiny}" "${RENDER:=64x32x2}" "${RSS_SET:=tiny}" "${RSS_FRAMES:=12 4}"
fi
export RENDER=${RENDER:-1920x1080x4} RSS_SET=${RSS_SET:-small} RSS_FRAMES=${RSS_FRAMES:-300 30}
bash bench/build-release.sh "$build_dir" hdrd
build_type=$(sed -n 's/^CMAKE_BUILD_TYPE:STRING=//p' "$build_dir/CMakeCache.txt")
command -v oiiotool >/dev/null || { echo "run-sequence: oiiotool missing (apt-get install openimageio-tools)" >&2; exit 77; }

work="$build_dir/bench-sequence"
# shellcheck disable=SC2086
bash bench/make-pans.sh "$work" $(printf '%s\n' ${SIZES:-1080p 4k} "$RSS_SET" | sort -u)

exec python3 - "$build_dir" "$work" "${REPS:-3}" "${SIZES:-1080p 4k}" "$build_type" <<'PY'
import json, os, random, shutil, statistics, subprocess, sys, tempfile, time

build, work, reps, sizes, build_type = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4].split(), sys.argv[5]
hdrd = os.path.join(build, "tools", "hdrd")
scratch = tempfile.mkdtemp(prefix="hdrd-bench-seq-", dir="/dev/shm" if os.path.isdir("/dev/shm") else None)

def run(args):
    """Runs hdrd; returns (wall s, cpu s of the child, parsed --json stdout)."""
    before = os.times()
    t0 = time.monotonic()
    p = subprocess.run([hdrd] + args + ["--json", "-q"], capture_output=True, text=True)
    wall = time.monotonic() - t0
    after = os.times()
    if p.returncode != 0:
        sys.exit(f"run-sequence: hdrd {' '.join(args)} failed: {p.stderr.strip()}")
    cpu = (after.children_user - before.children_user) + (after.children_system - before.children_system)
    return wall, cpu, json.loads(p.stdout)

def perf_works():
    if not shutil.which("perf"):
        return False
    p = subprocess.run(["perf", "record", "-q", "-o", os.path.join(scratch, "probe.data"), "true"], capture_output=True)
    return p.returncode == 0

def sampled_encoder_cpu(args, frames):
    """CPU ms per frame in the video encoder's own code (libx265, SVT-AV1, libaom): its
    share of perf's samples of one run times the run's CPU; None without perf."""
    if not use_perf:
        return None
    data = os.path.join(scratch, "perf.data")
    before = os.times()
    p = subprocess.run(["perf", "record", "-q", "-F", "999", "-o", data, "--", hdrd] + args + ["-q"], capture_output=True)
    after = os.times()
    if p.returncode != 0:
        return None
    cpu = (after.children_user - before.children_user) + (after.children_system - before.children_system)
    rep = subprocess.run(["perf", "report", "-i", data, "--sort", "dso", "--stdio", "-q"], capture_output=True, text=True)
    share = 0.0
    for line in rep.stdout.splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[0].endswith("%") and any(k in parts[1] for k in ("libx265", "libSvtAv1", "libaom")):
            share += float(parts[0].rstrip("%")) / 100
    for f in os.listdir(scratch):
        os.remove(os.path.join(scratch, f))
    return share * cpu / frames * 1e3 if share > 0 else None

def med(xs):
    return statistics.median(xs) if xs else None

use_perf = perf_works()
result = {"build_type": build_type, "reps": reps, "sizes": {}, "perf_sampling": use_perf}
for size in sizes:
    pattern = os.path.join(work, size, "pan.%03d.exr")
    frames = len([f for f in os.listdir(os.path.join(work, size)) if f.startswith("pan.")])
    runs = {"video": [], "own": []}
    for _ in range(reps):
        order = ["video", "own"]
        random.shuffle(order)
        for case in order:
            out = os.path.join(scratch, f"{size}-{case}")
            args = ["encode", pattern, "-o", out] + (["--video", "hevc"] if case == "video" else ["--format", "raw"])
            runs[case].append(run(args))
            for f in os.listdir(scratch):
                os.remove(os.path.join(scratch, f))
    per = lambda case, key: med([r[2]["timings_ms"].get(key, 0.0) / frames for r in runs[case]])
    split = {k: per("video", k) for k in ["read", "encode", "encode_cpu", "video_ycbcr", "video_ycbcr_cpu", "metadata",
                                          "metadata_cpu", "video_encoder", "video_mux", "video"]}
    cpu_video = med([r[1] / frames * 1e3 for r in runs["video"]])
    cpu_own = med([r[1] / frames * 1e3 for r in runs["own"]])
    # The encoder's CPU: what the video adds to the process (which also pays for the raw
    # dumps of the run without video: the encoder comes out a little low, the ratio high).
    encoder_cpu = cpu_video - cpu_own - split["video_ycbcr_cpu"] - split["metadata_cpu"]
    # hdrd's own work outside reading and the encoder, in CPU ms of the video run itself:
    # meter + temporal decisions + tone map + encode, Y'CbCr, the metadata. Each is a
    # CpuMeter (its thread and the pool's tasks for it), so the encoder's threads running
    # beside them do not count.
    own_work = split["encode_cpu"] + split["video_ycbcr_cpu"] + split["metadata_cpu"]
    # The difference above also charges the encoder with what its threads cost the other
    # stages (EXR decoding, the kernel's cache) on a shared machine. A second view, where
    # perf can sample: the encoder library's share of the video run's samples x its CPU.
    encoder_cpu_sampled = sampled_encoder_cpu(["encode", pattern, "-o", os.path.join(scratch, f"{size}-perf"),
                                               "--video", "hevc"], frames)
    split["read_cpu_without_video"] = per("own", "read_cpu")
    result["sizes"][size] = {
        "frames": frames,
        "wall_ms_per_frame": {"video": med([r[0] / frames * 1e3 for r in runs["video"]]),
                              "no_video": med([r[0] / frames * 1e3 for r in runs["own"]])},
        "split_ms_per_frame": split,
        "cpu_ms_per_frame": {"with_video": cpu_video, "without_video": cpu_own, "video_encoder": encoder_cpu},
        "own_work_ms_per_frame": own_work,
        "own_over_encoder": own_work / encoder_cpu if encoder_cpu > 0 else None,
        "video_encoder_cpu_sampled": encoder_cpu_sampled,
        "own_over_encoder_sampled": own_work / encoder_cpu_sampled if encoder_cpu_sampled else None,
        "own_with_read_over_encoder": (own_work + split["read_cpu_without_video"]) / encoder_cpu if encoder_cpu > 0 else None,
    }

# A render sequence (1080p unless RENDER says): where a rendered frame's time goes.
rw, rh, rn = os.environ["RENDER"].split("x")
w, c, j = run(["render", "--scene", "hdr", "--frames", rn, "--width", rw, "--height", rh, "--video", "hevc",
               "-o", os.path.join(scratch, "render")])
n = j["frame_count"]
key = "render_1080p_ms_per_frame" if (rw, rh) == ("1920", "1080") else f"render_{rw}x{rh}_ms_per_frame"
result[key] = {k: v / n for k, v in j["timings_ms"].items() if isinstance(v, (int, float))}
result[key]["wall"] = w / n * 1e3
for f in os.listdir(scratch):
    os.remove(os.path.join(scratch, f))

# Resident memory over 300 frames (a list file cycling the 100 small frames) vs 30 frames.
def rss_run(count):
    lst = os.path.join(scratch, f"list{count}.txt")
    small = os.path.join(work, os.environ["RSS_SET"])
    have = len([f for f in os.listdir(small) if f.startswith("pan.")])
    with open(lst, "w") as f:
        for i in range(count):
            f.write(os.path.join(os.path.abspath(small), "pan.%03d.exr" % (i % have)) + "\n")
    p = subprocess.Popen([hdrd, "encode", lst, "--video", "hevc", "-o", os.path.join(scratch, f"rss{count}"), "-q"],
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    samples = []
    while p.poll() is None:
        try:
            with open(f"/proc/{p.pid}/status") as s:
                for line in s:
                    if line.startswith("VmRSS:"):
                        samples.append(int(line.split()[1]) / 1024)
        except FileNotFoundError:
            pass
        time.sleep(0.05)
    if p.returncode != 0:
        sys.exit("run-sequence: rss run failed: " + p.stderr.read().decode())
    return samples

# The encoder fills its lookahead and frame threads over the first frames: compare the
# second sixth of the run (frames ~50-100, after that warm-up) with the last (250-300).
long_n, short_n = (int(v) for v in os.environ["RSS_FRAMES"].split())
s300, s30 = rss_run(long_n), rss_run(short_n)
if not s300 or not s30:  # a run too short to sample (the smoke run's tiny frames)
    s300, s30 = s300 or [0.0], s30 or [0.0]
k = max(1, len(s300) // 6)
result["rss_mb"] = {f"{long_n}_frames": {"second_sixth_median": med(s300[k:2 * k]), "last_sixth_median": med(s300[-k:]),
                                         "peak": max(s300)},
                    f"{short_n}_frames_peak": max(s30)}
second = result["rss_mb"][f"{long_n}_frames"]["second_sixth_median"]
result["rss_mb"]["growth_last_over_second_sixth"] = \
    result["rss_mb"][f"{long_n}_frames"]["last_sixth_median"] / second if second else None
shutil.rmtree(scratch, ignore_errors=True)
print(json.dumps(result))
PY
