#!/usr/bin/env bash
# A stand-in for `hdrd sequence plan|run|merge` that obeys the same contract (docs/cluster.md,
# "The contract") and does no rendering, so the cluster tests check the engines, not hdrd.
# The tests take the program from HDRD_BIN; pointed at the real hdrd they run it instead.
#
#   plan --shards N -o PLAN.json [--frames F]   work dir PLAN.json.d/, outbase null
#   run PLAN.json --shard I                     frames of shard I into work_dir/shard-I.txt,
#                                               then work_dir/shard-I.done
#   merge PLAN.json -o OUTBASE                  OUTBASE.mp4 = the shards' text in order;
#                                               exit 1 with one line when a shard is missing
set -euo pipefail
prog=hdrd
die() { echo "hdrd: $*" >&2; exit 1; }

# The plan reader deploy/ uses: sets PLAN_SHARDS, PLAN_FRAMES, PLAN_WORK_DIR.
. "$(dirname "${BASH_SOURCE[0]}")/../../deploy/lib/plan.sh"
read_plan() {
  plan_read "$1" || exit 1
  n=$PLAN_SHARDS frames=$PLAN_FRAMES work=$PLAN_WORK_DIR
}

[ "${1:-}" = sequence ] || die "the stand-in knows only 'sequence'"
verb=${2:-}
shift 2
case "$verb" in
  plan)
    shards="" out="" frames=12
    while [ $# -gt 0 ]; do
      case "$1" in
        --shards) shards=$2; shift 2 ;;
        -o) out=$2; shift 2 ;;
        --frames) frames=$2; shift 2 ;;
        *) shift ;;
      esac
    done
    [[ "$shards" =~ ^[1-9][0-9]*$ ]] || die "sequence plan: --shards needs an integer >= 1"
    [ -n "$out" ] || die "sequence plan: -o PLAN.json is required"
    out=$(cd "$(dirname "$out")" && pwd)/$(basename "$out")
    mkdir -p "$out.d"
    printf '{"format": "hdrd-sequence-plan", "shards": %d, "frames": %d, "work_dir": "%s", "outbase": null}\n' \
      "$shards" "$frames" "$out.d" >"$out"
    ;;
  run)
    plan=$1 shard=${3:-}
    [ "${2:-}" = --shard ] || die "sequence run: usage: run PLAN.json --shard I"
    read_plan "$plan"
    [[ "$shard" =~ ^[0-9]+$ ]] && (( shard < n )) || die "sequence run: --shard $shard: expected 0..$((n - 1))"
    first=$(( shard * frames / n )) last=$(( (shard + 1) * frames / n ))
    tmp=$(mktemp "$work/.shard-$shard.XXXXXX")
    for ((f = first; f < last; ++f)); do echo "frame $f"; done >"$tmp"
    mv "$tmp" "$work/shard-$shard.txt"
    : >"$work/shard-$shard.done"
    ;;
  merge)
    plan=$1 outbase=${3:-}
    [ "${2:-}" = -o ] && [ -n "$outbase" ] || die "sequence merge: usage: merge PLAN.json -o OUTBASE"
    read_plan "$plan"
    for ((i = 0; i < n; ++i)); do
      [ -e "$work/shard-$i.done" ] || die "sequence merge: shard $i of $n is missing (no $work/shard-$i.done)"
    done
    tmp=$(mktemp "$outbase.XXXXXX")
    for ((i = 0; i < n; ++i)); do cat "$work/shard-$i.txt"; done >"$tmp"
    mv "$tmp" "$outbase.mp4"
    ;;
  *) die "sequence: unknown verb '$verb'" ;;
esac
