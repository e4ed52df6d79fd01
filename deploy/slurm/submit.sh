#!/usr/bin/env bash
# Submits an `hdrd sequence plan` to Slurm: one job array with a task per shard, and a merge
# job that runs only after every task succeeded (docs/cluster.md).
#
#   deploy/slurm/submit.sh PLAN.json OUTBASE [--shards LIST] [--max-parallel K] [--json]
#                          [--dry-run] [--] [sbatch options...]
#
#   --shards LIST     submit only these shards (Slurm array syntax: 1,4-6), e.g. to rerun the
#                     failed ones; the merge then waits for them only (the others' shard-I.done
#                     files are already there, and the merge refuses any that is missing)
#   --max-parallel K  at most K shards run at once (sbatch --array=...%K)
#   --json            print {"array_job_id":..., "merge_job_id":..., ...} instead of two lines
#   --dry-run         print the two sbatch command lines and submit nothing
#   sbatch options    everything else (and everything after --) goes to both sbatch calls,
#                     after ours, so it wins: --partition=, --account=, --time=, --cpus-per-task=
#
# Environment: HDRD_BIN, the hdrd program as the compute nodes see it (default: hdrd on their
# PATH); SLURM_CONF and the rest of Slurm's own variables as sbatch reads them.
# Prints "array_job_id=ID" and "merge_job_id=ID" on stdout. Exit status 1 with one line on
# stderr when the plan, the options or a submission are wrong (a merge job that cannot be
# submitted cancels the array job it would have waited for).
set -euo pipefail
prog=submit.sh
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
# shellcheck source=../lib/plan.sh
. "$here/../lib/plan.sh"

die() { echo "$prog: $*" >&2; exit 1; }
usage() { die "usage: $prog PLAN.json OUTBASE [--shards LIST] [--max-parallel K] [--json] [--dry-run] [--] [sbatch options...]"; }

# Checks a Slurm array index list against the plan: comma-separated I or I-J, 0 <= I <= J < N.
check_shards() {
  local list=$1 n=$2 item a b
  [[ "$list" =~ ^[0-9]+(-[0-9]+)?(,[0-9]+(-[0-9]+)?)*$ ]] || die "--shards $list: expected a list like 0,3-5"
  IFS=, read -r -a items <<<"$list"
  for item in "${items[@]}"; do
    a=$((10#${item%-*})) b=$((10#${item#*-}))
    (( a <= b )) || die "--shards $list: range $item runs backwards"
    (( b < n )) || die "--shards $list: shard $b is out of range (the plan has $n shards: 0-$((n - 1)))"
  done
}

[ $# -ge 2 ] || usage
plan=$1 outbase=$2
shift 2
shards="" max_parallel="" json=0 dry_run=0
while [ $# -gt 0 ]; do
  case "$1" in
    --shards) [ $# -ge 2 ] || usage; shards=$2; shift 2 ;;
    --shards=*) shards=${1#*=}; shift ;;
    --max-parallel) [ $# -ge 2 ] || usage; max_parallel=$2; shift 2 ;;
    --max-parallel=*) max_parallel=${1#*=}; shift ;;
    --json) json=1; shift ;;
    --dry-run) dry_run=1; shift ;;
    --) shift; break ;;
    *) break ;;
  esac
done
sbatch_options=("$@")

plan_read "$plan" || exit 1
[ -n "$outbase" ] || die "OUTBASE is empty"
case "$outbase" in /*) ;; *) outbase=$PWD/$outbase ;; esac
[ -d "$(dirname "$outbase")" ] || die "OUTBASE $outbase: its folder does not exist"
if [ -n "$shards" ]; then check_shards "$shards" "$PLAN_SHARDS"; else shards="0-$((PLAN_SHARDS - 1))"; fi
if [ -n "$max_parallel" ]; then
  [[ "$max_parallel" =~ ^[1-9][0-9]*$ ]] || die "--max-parallel $max_parallel: expected an integer >= 1"
  shards="$shards%$max_parallel"
fi
hdrd=${HDRD_BIN:-hdrd}
mkdir -p "$PLAN_WORK_DIR" 2>/dev/null || die "work dir $PLAN_WORK_DIR cannot be created"

array_cmd=(sbatch --parsable "--array=$shards" "--chdir=$PLAN_WORK_DIR" "${sbatch_options[@]}"
           "$here/shard.sbatch" "$PLAN_PATH" "$hdrd")
merge_cmd=(sbatch --parsable "--dependency=afterok:ARRAY_JOB_ID" "--chdir=$PLAN_WORK_DIR" "${sbatch_options[@]}"
           "$here/merge.sbatch" "$PLAN_PATH" "$outbase" "$hdrd")
if [ "$dry_run" = 1 ]; then
  printf '%q ' "${array_cmd[@]}"; echo
  printf '%q ' "${merge_cmd[@]}"; echo
  exit 0
fi

# submit VAR sbatch ...: sets VAR to the job id, or `why` to what went wrong and returns 1.
# sbatch --parsable prints "ID" or "ID;CLUSTER"; its own error line goes into ours.
submit() {
  local var=$1 out err
  shift
  if ! out=$("$@" 2>"$tmp_err"); then
    err=$(<"$tmp_err")
    why=${err//$'\n'/ }
    return 1
  fi
  if ! [[ "${out%%;*}" =~ ^[0-9]+$ ]]; then
    why="sbatch printed '${out//$'\n'/ }', expected a job id"
    return 1
  fi
  printf -v "$var" '%s' "${out%%;*}"
}
tmp_err=$(mktemp)
trap 'rm -f "$tmp_err"' EXIT
why="" array_id="" merge_id=""
submit array_id "${array_cmd[@]}" || die "the shards' array job was not submitted: $why"
merge_cmd[2]="--dependency=afterok:$array_id"
if ! submit merge_id "${merge_cmd[@]}"; then
  scancel "$array_id" 2>/dev/null || true
  die "the merge job was not submitted ($why); array job $array_id cancelled"
fi

if [ "$json" = 1 ]; then
  if command -v jq >/dev/null 2>&1; then
    jq -nc --arg a "$array_id" --arg m "$merge_id" --arg s "$shards" --argjson n "$PLAN_SHARDS" \
      --arg p "$PLAN_PATH" --arg o "$outbase" --arg w "$PLAN_WORK_DIR" \
      '{array_job_id: $a, merge_job_id: $m, array: $s, shards: $n, plan: $p, outbase: $o, work_dir: $w}'
  else
    python3 -c 'import json, sys; a = sys.argv; print(json.dumps({"array_job_id": a[1], "merge_job_id": a[2], "array": a[3], "shards": int(a[4]), "plan": a[5], "outbase": a[6], "work_dir": a[7]}))' \
      "$array_id" "$merge_id" "$shards" "$PLAN_SHARDS" "$PLAN_PATH" "$outbase" "$PLAN_WORK_DIR"
  fi
else
  echo "array_job_id=$array_id"
  echo "merge_job_id=$merge_id"
fi
