#!/usr/bin/env bash
# A stand-in for `hdrd sequence plan|run|merge` that obeys the same contract (docs/cluster.md,
# "The contract") and does no rendering, so the cluster tests check the engines, not hdrd.
# The tests take the program from HDRD_BIN; pointed at the real hdrd they run it instead.
#
#   plan --shards N -o PLAN.json [--frames F]   work dir PLAN.json.d/, outbase null
#   run PLAN.json --shard I                     frames of shard I into work_dir/shard-I.txt,
#                                               then work_dir/shard-I.done
#   merge PLAN.json -o OUTBASE                  OUTBASE.mp4 = the shards' text in order,
#                                               OUTBASE.json = {"frames": F}; exit 1 with
#                                               one line when a shard is missing
#   encode --frames F -o OUTBASE                the one-process run: the same two files
set -euo pipefail
prog=hdrd
die() { echo "hdrd: $*" >&2; exit 1; }

# The plan reader deploy/ uses: sets PLAN_SHARDS, PLAN_FRAMES, PLAN_WORK_DIR.
. "$(dirname "${BASH_SOURCE[0]}")/../../deploy/lib/plan.sh"
read_plan() {
  plan_read "$1" || exit 1
  n=$PLAN_SHARDS frames=$PLAN_FRAMES work=$PLAN_WORK_DIR
}

# write_outputs OUTBASE FRAMES < the frames' text: OUTBASE.mp4 and OUTBASE.json, each
# renamed into place whole.
write_outputs() {
  local tmp
  tmp=$(mktemp "$1.XXXXXX")
  cat >"$tmp"
  mv "$tmp" "$1.mp4"
  tmp=$(mktemp "$1.XXXXXX")
  printf '{"frames": %d}\n' "$2" >"$tmp"
  mv "$tmp" "$1.json"
}

if [ "${1:-}" = encode ]; then  # the one-process run the sharded one must equal
  shift
  out="" frames=12
  while [ $# -gt 0 ]; do
    case "$1" in
      -o) out=$2; shift 2 ;;
      --frames) frames=$2; shift 2 ;;
      *) shift ;;
    esac
  done
  [ -n "$out" ] || die "encode: -o OUTBASE is required"
  for ((f = 0; f < frames; ++f)); do echo "frame $f"; done | write_outputs "$out" "$frames"
  exit 0
fi
[ "${1:-}" = sequence ] || die "the stand-in knows only 'sequence' and 'encode'"
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
    for ((i = 0; i < n; ++i)); do cat "$work/shard-$i.txt"; done | write_outputs "$outbase" "$frames"
    ;;
  *) die "sequence: unknown verb '$verb'" ;;
esac
