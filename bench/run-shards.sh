#!/usr/bin/env bash
# A 240-frame 1080p sequence (docs/cluster.md "Cost model"): one `hdrd encode` process
# against `hdrd sequence plan` + N parallel `hdrd sequence run` + `hdrd sequence merge` for
# N = 2 and 4 shards on this machine, HEVC at the default preset. Reports the wall time of
# each step (the analysis pass, the slowest shard, the merge), the per-frame costs the model
# is written in, and checks that every sharded result has the one-process frames. The frames
# are the 1080p pan of bench/run-sequence.sh (24 crops of MtTamWest.exr), cycled to 240.
# The last line is one JSON object.
# env: BUILD_DIR (default build-release), FRAMES (240), SHARDS ("2 4"), PAN (the pan set,
#      default 1080p), NO_BUILD=1, BENCH_SMOKE=1 (CI: 8 frames of the 64x32 pan in 2 shards;
#      skips with exit 77 without oiiotool or the fixture)
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${BUILD_DIR:-build-release}
if [ "${BENCH_SMOKE:-0}" = 1 ]; then : "${FRAMES:=8}" "${SHARDS:=2}" "${PAN:=tiny}"; fi
pan_set=${PAN:-1080p}
bash bench/build-release.sh "$build_dir" hdrd
pan_dir="$build_dir/bench-sequence/$pan_set"
bash bench/make-pans.sh "$build_dir/bench-sequence" "$pan_set"
[ -f "$pan_dir/pan.000.exr" ] || { echo "run-shards: the $pan_set pan is missing (bench/make-pans.sh makes it)" >&2; exit 1; }

exec python3 - "$build_dir" "$pan_dir" "${FRAMES:-240}" "${SHARDS:-2 4}" <<'PY'
import json, os, shutil, subprocess, sys, tempfile, time

build, pan, frames, shard_counts = sys.argv[1], os.path.abspath(sys.argv[2]), int(sys.argv[3]), [int(s) for s in sys.argv[4].split()]
pan_frames = len([f for f in os.listdir(pan) if f.startswith("pan.")])
hdrd = os.path.join(build, "tools", "hdrd")
work = tempfile.mkdtemp(prefix="hdrd-bench-shards-")
lst = os.path.join(work, "frames.txt")
with open(lst, "w") as f:
    for i in range(frames):
        f.write(os.path.join(pan, "pan.%03d.exr" % (i % pan_frames)) + "\n")
seq = ["encode", lst, "--video", "hevc", "--format", "raw"]

def timed(*cmds):
    """Runs the commands at once; returns the wall time until the last ends."""
    t0 = time.monotonic()
    procs = [subprocess.Popen([hdrd] + c + ["-q"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE) for c in cmds]
    for p, c in zip(procs, cmds):
        if p.wait() != 0:
            sys.exit(f"run-shards: hdrd {' '.join(c)} failed: {p.stderr.read().decode().strip()}")
    return time.monotonic() - t0

def raw(base, i):
    with open(f"{base}.{i:05d}.raw", "rb") as f:
        return f.read()

out = {"frames": frames, "pan": os.path.basename(pan), "codec": "hevc (x265 medium)", "cores": os.cpu_count()}
one = os.path.join(work, "one", "seq")
os.makedirs(os.path.dirname(one))
out["one_process_s"] = timed(seq + ["-o", one])
out["shards"] = {}
for n in shard_counts:
    d = os.path.join(work, f"n{n}")
    os.makedirs(d)
    plan = os.path.join(d, "plan.json")
    t_plan = timed(["sequence", "plan", "--shards", str(n), "-o", plan] + seq)
    t_run = timed(*[["sequence", "run", plan, "--shard", str(i)] for i in range(n)])
    t_merge = timed(["sequence", "merge", plan, "-o", os.path.join(d, "seq")])
    same = all(raw(os.path.join(d, "seq"), i) == raw(one, i) for i in range(0, frames, max(1, frames // 24)))
    out["shards"][str(n)] = {"plan_s": t_plan, "shards_s": t_run, "merge_s": t_merge,
                             "total_s": t_plan + t_run + t_merge,
                             "over_one_process": (t_plan + t_run + t_merge) / out["one_process_s"],
                             "analysis_ms_per_frame": t_plan / frames * 1e3,
                             "frames_equal_one_process": same}
    shutil.rmtree(os.path.join(d, "plan.json.d"), ignore_errors=True)
shutil.rmtree(work, ignore_errors=True)
print(json.dumps(out))
PY
