#!/usr/bin/env bash
# deploy/slurm/submit.sh without a cluster: a recording sbatch/scancel on PATH checks the
# command lines it builds from a plan and its options, its output, and that it refuses bad
# plans and options with one line. Runs everywhere (the real cluster: slurm_e2e_test.sh).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
submit=$(cd "$here/../.." && pwd)/deploy/slurm/submit.sh
tmp=$(mktemp -d /tmp/hdrd-submit-test.XXXXXX)
trap 'rm -rf "$tmp"' EXIT
failures=0
fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }
check() { local what=$1; shift; if "$@"; then echo "ok: $what"; else fail "$what"; fi; }

# The recording sbatch: appends its argv (one argument a line, then "--end--") to calls.log,
# prints the next id from ids (one a line; "FAIL" makes that call exit 1).
mkdir -p "$tmp/bin"
cat >"$tmp/bin/sbatch" <<'EOF'
#!/usr/bin/env bash
printf '%s\n' "$@" --end-- >>"$FAKE_DIR/calls.log"
n=$(grep -c -- '^--end--$' "$FAKE_DIR/calls.log")
id=$(sed -n "${n}p" "$FAKE_DIR/ids")
[ "$id" = FAIL ] && { echo "sbatch: error: Batch job submission failed: Invalid partition name specified" >&2; exit 1; }
echo "$id"
EOF
cat >"$tmp/bin/scancel" <<'EOF'
#!/usr/bin/env bash
echo "scancel $*" >>"$FAKE_DIR/scancel.log"
EOF
chmod +x "$tmp/bin/sbatch" "$tmp/bin/scancel"
export PATH=$tmp/bin:$PATH FAKE_DIR=$tmp

reset() { rm -f "$tmp/calls.log" "$tmp/scancel.log"; printf '%s\n' "$@" >"$tmp/ids"; }
# call K: the K-th sbatch call's arguments, space-separated.
call() { awk -v k="$1" '$0 == "--end--" { ++n; next } n == k - 1 { printf "%s ", $0 }' "$tmp/calls.log"; }
calls() { grep -c -- '^--end--$' "$tmp/calls.log" 2>/dev/null || echo 0; }
# refuses WHAT EXPECTED ARGS...: exit 1, nothing on stdout, one stderr line containing EXPECTED.
refuses() {
  local what=$1 expected=$2 out err rc=0
  shift 2
  out=$("$submit" "$@" 2>"$tmp/err") || rc=$?
  err=$(cat "$tmp/err")
  if [ "$rc" = 1 ] && [ -z "$out" ] && [ "$(wc -l <"$tmp/err")" = 1 ] && [[ "$err" == *"$expected"* ]]; then
    echo "ok: refuses $what"
  else
    fail "refuses $what: rc=$rc out='$out' err='$err' (expected '$expected')"
  fi
}

mkdir -p "$tmp/plans/w" "$tmp/out"
plan=$tmp/plans/p.json
echo '{"format": "hdrd-sequence-plan", "shards": 3, "frames": 30, "work_dir": "w", "outbase": null}' >"$plan"
scripts=$(dirname "$submit")

# A plain submission: the array, then the merge after it; sbatch options after ours.
reset 101 "102;cluster1"
out=$(cd "$tmp" && HDRD_BIN=/opt/hdrd/bin/hdrd "$submit" plans/p.json out/seq -p fast --time=10)
check "prints both ids" test "$out" = "$(printf 'array_job_id=101\nmerge_job_id=102')"
check "two sbatch calls" test "$(calls)" = 2
check "the array: one task per shard, run in the work dir, shard.sbatch PLAN HDRD_BIN" \
  test "$(call 1)" = "--parsable --array=0-2 --chdir=$tmp/plans/w -p fast --time=10 $scripts/shard.sbatch $plan /opt/hdrd/bin/hdrd "
check "the merge: afterok on the array, merge.sbatch PLAN OUTBASE HDRD_BIN" \
  test "$(call 2)" = "--parsable --dependency=afterok:101 --chdir=$tmp/plans/w -p fast --time=10 $scripts/merge.sbatch $plan $tmp/out/seq /opt/hdrd/bin/hdrd "

# --shards, --max-parallel, --json, --.
reset 7 8
out=$("$submit" "$plan" "$tmp/out/seq" --shards 1,2 --max-parallel 2 --json -- --qos=low)
check "--json prints the ids and the plan's facts" \
  test "$(jq -c . <<<"$out")" = "$(jq -nc --arg p "$plan" --arg o "$tmp/out/seq" --arg w "$tmp/plans/w" \
    '{array_job_id: "7", merge_job_id: "8", array: "1,2%2", shards: 3, plan: $p, outbase: $o, work_dir: $w}')"
check "--shards and --max-parallel make the array spec" test "$(call 1 | cut -d' ' -f2)" = "--array=1,2%2"
check "options after -- go to sbatch" test "$(call 2 | cut -d' ' -f4)" = "--qos=low"
check "HDRD_BIN defaults to hdrd" test "$(call 1 | awk '{ print $NF }')" = hdrd

# --dry-run submits nothing.
reset 1 2
out=$("$submit" "$plan" "$tmp/out/seq" --dry-run)
check "--dry-run prints two command lines" test "$(wc -l <<<"$out")" = 2
check "--dry-run calls no sbatch" test "$(calls)" = 0

# A merge that cannot be submitted cancels the array.
reset 55 FAIL
refuses "a merge sbatch refused" "the merge job was not submitted (sbatch: error: Batch job submission failed: Invalid partition name specified); array job 55 cancelled" "$plan" "$tmp/out/seq"
check "... and cancels the array job" test "$(cat "$tmp/scancel.log")" = "scancel 55"
reset "Submitted batch job 9"
refuses "an sbatch answer that is not an id" "the shards' array job was not submitted: sbatch printed 'Submitted batch job 9', expected a job id" "$plan" "$tmp/out/seq"

# Bad options and plans, through both plan readers.
reset 1 2
refuses "a shard out of range" "shard 3 is out of range (the plan has 3 shards: 0-2)" "$plan" "$tmp/out/seq" --shards 0,3
refuses "a backwards range" "range 2-1 runs backwards" "$plan" "$tmp/out/seq" --shards 2-1
refuses "a malformed list" "expected a list like 0,3-5" "$plan" "$tmp/out/seq" --shards 1,,2
refuses "--max-parallel 0" "--max-parallel 0: expected an integer >= 1" "$plan" "$tmp/out/seq" --max-parallel 0
refuses "an OUTBASE in a missing folder" "its folder does not exist" "$plan" "$tmp/nowhere/seq"
refuses "too few arguments" "usage:" "$plan"
# The plan-header rules, case by case from the table daemon/cluster/slurm.cpp is tested on too.
# One jq run writes case-N.json and case-N.expect (the error, empty for a good plan).
mkdir -p "$tmp/cases"
count=$(jq '.cases | length' "$here/plan_header_cases.json")
for ((c = 0; c < count; ++c)); do
  jq -j ".cases[$c].text" "$here/plan_header_cases.json" >"$tmp/cases/case-$c.json"
done
jq -r '.cases[] | "\(.error // "")|\(.name)"' "$here/plan_header_cases.json" >"$tmp/cases/index.txt"
# plan_read itself (in a subshell, as submit.sh calls it) for the table; submit.sh for the
# prefix and the exit status on two of them.
. "$(dirname "$submit")/../lib/plan.sh"
for reader in jq python3; do
  export HDRD_PLAN_READER=$reader
  refuses "a missing plan ($reader)" "plan $tmp/none.json: no such file" "$tmp/none.json" "$tmp/out/seq"
  refuses "a bad plan ($reader)" "submit.sh: plan $tmp/cases/case-8.json: shards is 0" "$tmp/cases/case-8.json" "$tmp/out/seq"
  c=0
  while IFS='|' read -r expected name; do
    plan_c=$tmp/cases/case-$c.json
    c=$((c + 1))
    rc=0
    err=$( (prog=submit.sh; plan_read "$plan_c") 2>&1 >/dev/null) || rc=$?
    if [ -n "$expected" ]; then
      if [ "$rc" = 1 ] && [ "$err" = "submit.sh: plan $plan_c: $expected" ]; then echo "ok: refuses a plan with $name ($reader)"
      else fail "refuses a plan with $name ($reader): rc=$rc '$err' (expected '$expected')"; fi
    elif [ "$rc" = 0 ] && [ -z "$err" ]; then
      echo "ok: reads a plan with $name ($reader)"
    else
      fail "reads a plan with $name ($reader): rc=$rc '$err'"
    fi
  done <"$tmp/cases/index.txt"
done
unset HDRD_PLAN_READER
check "no refused submission called sbatch" test "$(calls)" = 0

[ "$failures" = 0 ] || { echo "$failures check(s) failed" >&2; exit 1; }
echo "all checks passed"
