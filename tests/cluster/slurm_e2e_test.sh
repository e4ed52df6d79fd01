#!/usr/bin/env bash
# End to end on a real one-node Slurm cluster (scripts/slurm-local.sh, started by the ctest
# fixture cluster.slurm.start into CLUSTER_DIR): deploy/slurm/submit.sh submits a 3-shard
# plan, and the test checks from Slurm's own records (squeue, the job completion log) that
#   1. every shard ran exactly once and succeeded, the merge ran after all of them, and the
#      merged output exists (and, with the stand-in, holds every frame once, in order);
#   2. a failing shard keeps the merge from running (afterok; it is cancelled);
#   3. resubmitting only the failed shard (--shards 1) completes the sequence;
#   4. the sharded result equals a one-process run of the same options (same_outputs).
#
#   tests/cluster/slurm_e2e_test.sh CLUSTER_DIR
# HDRD_BIN: the program under test (default: the stand-in beside this script); the jobs run
# it through run_log_wrapper.sh, which logs every call and fails shard I on demand.
# HDRD_PLAN_ARGS: what follows `hdrd sequence plan --shards 3 -o PLAN.json` (default:
# --frames 12, which the stand-in takes). Exit 77 (skip) when there is no cluster here.
# HDRD_ONE_PROCESS_ARGS: the one-process run of the same sequence, `$HDRD_BIN ARGS -o OUTBASE`
# (default for the stand-in: encode --frames 12); unset with a real HDRD_BIN: part 4 is
# skipped, saying so.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
cluster=${1:?usage: slurm_e2e_test.sh CLUSTER_DIR}
if [ ! -f "$cluster/env.sh" ]; then
  reason=$("$root/scripts/slurm-local.sh" check) && reason="the cluster fixture (cluster.slurm.start) did not start one"
  echo "SKIP: no local Slurm cluster: $reason"
  exit 77
fi
command -v jq >/dev/null || { echo "SKIP: jq missing (Debian package jq)"; exit 77; }
. "$cluster/env.sh"
program=${HDRD_BIN:-$here/stand_in_hdrd.sh}
read -r -a plan_args <<<"${HDRD_PLAN_ARGS:---frames 12}"
stand_in=0
[ "$program" = "$here/stand_in_hdrd.sh" ] && stand_in=1
# The jobs inherit the submitting environment (sbatch --export=ALL, its default).
export HDRD_WRAPPED=$program HDRD_BIN=$here/run_log_wrapper.sh
work=$(mktemp -d /tmp/hdrd-slurm-e2e.XXXXXX)
trap 'rm -rf "$work"' EXIT
mkdir "$work/out"  # OUTBASEs here: the check of part 4 compares every OUTBASE.* file
n=3
failures=0

fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }
check() { local what=$1; shift; if "$@"; then echo "ok: $what"; else fail "$what"; fi; }

# Waits (at most 60 s) until none of the jobs is pending, running or completing.
wait_jobs() {
  local ids=$1 t0=$SECONDS
  while squeue -h -r -t all -j "$ids" -o '%T' | grep -Eq '^(PENDING|CONFIGURING|RUNNING|COMPLETING|REQUEUED|RESIZING|SUSPENDED)$'; do
    if (( SECONDS - t0 > 60 )); then squeue -r -t all -j "$ids" >&2; return 1; fi
    sleep 0.2
  done
}
# "TASK STATE" per array task of job $1, sorted by task.
task_states() { squeue -h -r -t all -j "$1" -o '%K %T' | sort -n; }
job_state() { squeue -h -t all -j "$1" -o '%T'; }
job_reason() { squeue -h -t all -j "$1" -o '%r'; }
# The completion log's records (one per finished job or array task): KEY=VALUE fields.
jobcomp_field() {  # jobcomp_field FILTER_KEY FILTER_VALUE FIELD
  grep -o "JobId=[^ ]* .*" "$cluster/log/jobcomp.txt" | awk -v k="$1" -v v="$2" -v f="$3" '
    { delete r; for (i = 1; i <= NF; ++i) { split($i, kv, "="); r[kv[1]] = substr($i, length(kv[1]) + 2) }
      if (r[k] == v) print r[f] }'
}
epoch() { date -d "$1" +%s; }

submit() {  # submit PLAN OUTBASE [submit.sh options]: sets array_id and merge_id
  local out t0 t1
  t0=$(date +%s%N)
  out=$("$root/deploy/slurm/submit.sh" "$@" --json)
  t1=$(date +%s%N)
  array_id=$(jq -r .array_job_id <<<"$out")
  merge_id=$(jq -r .merge_job_id <<<"$out")
  echo "submitted array $array_id, merge $merge_id in $(( (t1 - t0) / 1000000 )) ms"
}

# --- 1. a plan runs through: every shard once, then the merge ------------------------------
"$program" sequence plan --shards "$n" -o "$work/ok.plan.json" "${plan_args[@]}"
t_submit=$(date +%s%N)
submit "$work/ok.plan.json" "$work/out/ok"
wait_jobs "$array_id,$merge_id" || fail "the jobs did not finish within 60 s"
t_done=$(date +%s%N)
echo "array + merge finished $(( (t_done - t_submit) / 1000000 )) ms after submission"
check "every shard's array task completed" \
  test "$(task_states "$array_id")" = "$(printf '%s COMPLETED\n' $(seq 0 $((n - 1))))"
check "the merge job completed" test "$(job_state "$merge_id")" = COMPLETED
# Ran once: one completion record per task (a requeued or retried task would leave two).
for ((i = 0; i < n; ++i)); do
  records=$(grep -c "ArrayJobId=$array_id ArrayTaskId=$i " "$cluster/log/jobcomp.txt" || true)
  check "shard $i has one completion record" test "$records" = 1
done
last_shard_end=$(jobcomp_field ArrayJobId "$array_id" EndTime | while read -r t; do epoch "$t"; done | sort -n | tail -1)
merge_start=$(epoch "$(jobcomp_field JobId "$merge_id" StartTime)")
check "the merge started after the last shard ended (Slurm's clock)" test "$merge_start" -ge "$last_shard_end"
work_dir=$(jq -r .work_dir "$work/ok.plan.json")
check "the merged video exists" test -s "$work/out/ok.mp4"
if [ "$stand_in" = 1 ]; then
  check "the merged output holds every frame once, in order" \
    test "$(cat "$work/out/ok.mp4")" = "$(printf 'frame %d\n' $(seq 0 11))"
fi
check "each shard ran once, and succeeded (the wrapper's log)" \
  test "$(awk '$1 == "run" { print $2 $5 }' "$work_dir/runs.log" | sort | tr '\n' ' ')" = "00 10 20 "
check "the merge ran once" test "$(grep -c '^merge' "$work_dir/runs.log")" = 1
merge_start_ns=$(awk '$1 == "merge" { print $3 }' "$work_dir/runs.log")
last_end_ns=$(awk '$1 == "run" { print $4 }' "$work_dir/runs.log" | sort -n | tail -1)
check "the merge started after the last shard ended (nanosecond clock)" test "$merge_start_ns" -gt "$last_end_ns"

# --- 2. a failing shard: the merge is cancelled, never run ---------------------------------
"$program" sequence plan --shards "$n" -o "$work/bad.plan.json" "${plan_args[@]}"
bad_dir=$(jq -r .work_dir "$work/bad.plan.json")
: >"$bad_dir/fail-shard-1"
submit "$work/bad.plan.json" "$work/out/bad"
wait_jobs "$array_id,$merge_id" || fail "the failing plan's jobs did not finish within 60 s"
check "shard 1 failed, shards 0 and 2 completed" \
  test "$(task_states "$array_id")" = "$(printf '0 COMPLETED\n1 FAILED\n2 COMPLETED')"
check "the merge was cancelled" test "$(job_state "$merge_id")" = CANCELLED
check "... because its dependency can never be met" test "$(job_reason "$merge_id")" = DependencyNeverSatisfied
check "the merge wrote nothing" test -z "$(ls -A "$work/out" | grep "^bad\\." || true)"
check "the merge program never ran" test "$(grep -c '^merge' "$bad_dir/runs.log" || true)" = 0

# --- 3. retry: resubmit the failed shard only ----------------------------------------------
rm -f "$bad_dir/fail-shard-1"
submit "$work/bad.plan.json" "$work/out/bad" --shards 1
wait_jobs "$array_id,$merge_id" || fail "the retry's jobs did not finish within 60 s"
check "the retried shard completed" test "$(task_states "$array_id")" = "1 COMPLETED"
check "the retry's merge completed" test "$(job_state "$merge_id")" = COMPLETED
check "the retried sequence's merged video exists" test -s "$work/out/bad.mp4"
check "the retried sequence equals the clean run (same bytes)" cmp -s "$work/out/ok.mp4" "$work/out/bad.mp4"
check "shards 0 and 2 ran once, shard 1 failed once and then succeeded once" \
  test "$(awk '$1 == "run" { print $2 ":" $5 }' "$bad_dir/runs.log" | sort | tr '\n' ' ')" = "0:0 1:0 1:3 2:0 "

# --- 4. the sharded result equals the one-process run ------------------------------------
# same_outputs A B: the same OUTBASE.* files; a video's decoded frames equal (ffmpeg's
# framemd5: pts and the hash of each decoded frame, so container timestamps written at
# mux time cannot hide or fake a difference), JSON equal as data (jq -S), anything else
# byte for byte. Prints what differs.
video_frames() {  # video_frames FILE: "PTS HASH" per decoded frame; fails for a non-video
  ffprobe -v error -select_streams v:0 -show_entries stream=codec_type -of csv=p=0 "$1" 2>/dev/null | grep -q '^video' \
    && ffmpeg -nostdin -v error -i "$1" -map 0:v:0 -f framemd5 - | awk -F', *' '!/^#/ { print $3, $6 }'
}
# JSON as data, less what is measured, not made: every *_ms time (timings_ms, a render's
# render_ms) and the video's size in bytes (each shard's fresh encoder starts with a
# keyframe; the decoded frames are compared instead).
json_filter='walk(if type == "object" then with_entries(select(.key | endswith("_ms") | not)) else . end)
  | if (.video | type) == "object" then del(.video.bytes) else . end'
same_outputs() {
  local a=$1 b=$2 f suffix ok=0 fa fb
  if [ "$(cd "$(dirname "$a")" && ls -1 "$(basename "$a")".* | sed "s|^$(basename "$a")||")" != \
       "$(cd "$(dirname "$b")" && ls -1 "$(basename "$b")".* | sed "s|^$(basename "$b")||")" ]; then
    echo "different files: $(ls -1 "$a".* | tr '\n' ' ')vs $(ls -1 "$b".* | tr '\n' ' ')" >&2
    return 1
  fi
  for f in "$a".*; do
    suffix=${f#"$a"}
    if command -v ffprobe >/dev/null && fa=$(video_frames "$f") && [ -n "$fa" ]; then
      fb=$(video_frames "$b$suffix") || fb=""
      [ "$fa" = "$fb" ] || { echo "$suffix: the decoded frames differ: $(diff <(echo "$fa") <(echo "$fb") | head -3 | tr '\n' ' ')" >&2; ok=1; }
    elif [[ "$suffix" == *.json ]]; then
      cmp -s <(jq -S "$json_filter" "$f") <(jq -S "$json_filter" "$b$suffix") || {
        echo "$suffix: the JSON differs: $(diff <(jq -S "$json_filter" "$f") <(jq -S "$json_filter" "$b$suffix") | head -4 | tr '\n' ' ')" >&2
        ok=1
      }
    else
      cmp -s "$f" "$b$suffix" || { echo "$suffix: the bytes differ" >&2; ok=1; }
    fi
  done
  return "$ok"
}
one_args=${HDRD_ONE_PROCESS_ARGS-}
[ "$stand_in" = 1 ] && [ -z "$one_args" ] && one_args="encode ${plan_args[*]}"
if [ -n "$one_args" ]; then
  read -r -a one <<<"$one_args"
  mkdir -p "$work/one-process"
  t0=$(date +%s%N)
  "$program" "${one[@]}" -o "$work/one-process/ok"
  echo "the one-process run took $(( ($(date +%s%N) - t0) / 1000000 )) ms"
  check "the sharded result equals the one-process run ($one_args)" same_outputs "$work/one-process/ok" "$work/out/ok"
else
  echo "not checked: the sharded result against a one-process run (set HDRD_ONE_PROCESS_ARGS with HDRD_BIN)"
fi

if [ "$failures" -gt 0 ]; then
  echo "$failures check(s) failed; slurmctld log tail:" >&2
  tail -20 "$cluster/log/slurmctld.log" >&2
  exit 1
fi
echo "all checks passed"
