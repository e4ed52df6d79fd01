#!/usr/bin/env bash
# Runs `hdrd sequence run|merge ...` through $HDRD_WRAPPED (the program under test) and
# records each call in WORK_DIR/runs.log as "VERB SHARD START_NS END_NS STATUS", so a cluster
# test sees how often and in which order the engine ran it, whatever the program is. When
# WORK_DIR/fail-shard-I exists, shard I fails with status 3 without running (the tests' way
# to make one shard fail). WORK_DIR is the plan's work_dir.
set -uo pipefail
wrapped=${HDRD_WRAPPED:?HDRD_WRAPPED: the program to run}
verb=${2:-} plan=${3:-}
case "$verb" in
  run) shard=${5:-} ;;
  merge) shard=- ;;
  *) exec "$wrapped" "$@" ;;
esac
prog=run_log_wrapper
. "$(dirname "${BASH_SOURCE[0]}")/../../deploy/lib/plan.sh"
plan_read "$plan" || exit 1
work=$PLAN_WORK_DIR
start=$(date +%s%N)
if [ "$verb" = run ] && [ -e "$work/fail-shard-$shard" ]; then
  status=3
else
  "$wrapped" "$@"
  status=$?
fi
echo "$verb $shard $start $(date +%s%N) $status" >>"$work/runs.log"
exit "$status"
