#!/usr/bin/env bash
# What Slurm itself costs a sharded sequence (docs/cluster.md, "Cost model"): on the
# one-node test cluster (scripts/slurm-local.sh), with shards that do nothing (a `date`),
# so every second measured is the engine's, not hdrd's.
#
#   bench/slurm_overhead.sh [REPEATS] [SIZES]      default: 3 repeats of arrays of 1 4 16
#
# Per array size, the medians over the repeats of
#   start_s     the cluster from nothing to a node taking jobs (once per run)
#   submit_ms   deploy/slurm/submit.sh, both sbatch calls included
#   first_ms    submission -> the first task starts
#   last_ms     submission -> the last task ends
#   merge_ms    the last task ends -> the merge starts (afterok dependency latency)
#   total_ms    submission -> the merge ends
# Needs root and the packages (scripts/install-cluster-test-deps.sh). Prints a table and
# one JSON object per size.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
repeats=${1:-3}
sizes=${2:-1 4 16}
"$root/scripts/slurm-local.sh" check >/dev/null || { "$root/scripts/slurm-local.sh" check; exit 77; }
tmp=$(mktemp -d /tmp/hdrd-slurm-bench.XXXXXX)
cluster=$tmp/cluster
trap '"$root/scripts/slurm-local.sh" stop "$cluster" >/dev/null 2>&1 || true; rm -rf "$tmp"' EXIT
start_s=$("$root/scripts/slurm-local.sh" start "$cluster" 16 | jq .start_s)
. "$cluster/env.sh"

# A stand-in hdrd whose shards and merge only record when they ran (ns).
cat >"$tmp/timer.sh" <<'EOF'
#!/bin/sh
# sequence run PLAN --shard I | sequence merge PLAN -o OUT
start=$(date +%s%N)
work=$(dirname "$3")/work
if [ "$2" = run ]; then echo "run $5 $start $(date +%s%N)" >>"$work/times"; : >"$work/shard-$5.done"
else echo "merge - $start $(date +%s%N)" >>"$work/times"; fi
EOF
chmod +x "$tmp/timer.sh"
export HDRD_BIN=$tmp/timer.sh

median() { sort -n | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : int((v[NR / 2] + v[NR / 2 + 1]) / 2) }'; }

printf '%-6s %8s %10s %9s %9s %9s %9s\n' shards start_s submit_ms first_ms last_ms merge_ms total_ms
for n in $sizes; do
  : >"$tmp/rows"
  for ((r = 0; r < repeats; ++r)); do
    run=$tmp/n$n-r$r
    mkdir -p "$run/work"
    printf '{"format": "hdrd-sequence-plan", "shards": %d, "frames": %d, "work_dir": "%s"}\n' "$n" "$n" "$run/work" >"$run/plan.json"
    t0=$(date +%s%N)
    ids=$("$root/deploy/slurm/submit.sh" "$run/plan.json" "$run/out" --json)
    t1=$(date +%s%N)
    merge_id=$(jq -r .merge_job_id <<<"$ids")
    array_id=$(jq -r .array_job_id <<<"$ids")
    for _ in $(seq 600); do
      grep -q '^merge' "$run/work/times" 2>/dev/null && break
      sleep 0.1
    done
    grep -q '^merge' "$run/work/times" || { echo "array $array_id / merge $merge_id did not finish in 60 s" >&2; exit 1; }
    awk -v t0="$t0" -v t1="$t1" '
      $1 == "run" { if (!first || $3 < first) first = $3; if ($4 > last) last = $4 }
      $1 == "merge" { ms = $3; me = $4 }
      END { printf "%d %d %d %d %d\n", (t1 - t0) / 1e6, (first - t0) / 1e6, (last - t0) / 1e6, (ms - last) / 1e6, (me - t0) / 1e6 }' \
      "$run/work/times" >>"$tmp/rows"
  done
  cols=()
  for c in 1 2 3 4 5; do cols+=("$(awk -v c=$c '{ print $c }' "$tmp/rows" | median)"); done
  printf '%-6s %8s %10s %9s %9s %9s %9s\n' "$n" "$start_s" "${cols[@]}"
  jq -nc --argjson n "$n" --argjson s "$start_s" --argjson r "$repeats" \
    --argjson a "${cols[0]}" --argjson b "${cols[1]}" --argjson c "${cols[2]}" --argjson d "${cols[3]}" --argjson e "${cols[4]}" \
    '{shards: $n, repeats: $r, start_s: $s, submit_ms: $a, first_ms: $b, last_ms: $c, merge_ms: $d, total_ms: $e}' >&2
done
