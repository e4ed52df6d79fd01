# Sourced by deploy/slurm/submit.sh and deploy/k8s/render.sh: reads the header of an
# `hdrd sequence plan` file (docs/cluster.md, "The plan") with jq, or python3 where there is
# no jq (HDRD_PLAN_READER=jq|python3 forces one; both apply the same rules).
#
# plan_read PLAN.json sets
#   PLAN_PATH      the plan's absolute path
#   PLAN_SHARDS    N, the number of shards (an integer from 1 to 1000000)
#   PLAN_FRAMES    the number of frames (an integer >= 1)
#   PLAN_WORK_DIR  the absolute work dir (a relative one is relative to the plan's folder)
# or prints one line naming what is wrong on stderr ("$prog: plan PLAN.json: ...", where
# the sourcing script sets prog) and returns 1.

plan_read() {
  local plan=$1 reader=${HDRD_PLAN_READER:-} fields
  if [ ! -f "$plan" ]; then
    _plan_error "$plan" "no such file"
    return 1
  fi
  if [ -z "$reader" ]; then
    if command -v jq >/dev/null 2>&1; then reader=jq
    elif command -v python3 >/dev/null 2>&1; then reader=python3
    else
      _plan_error "$plan" "reading it needs python3 or jq, and neither is on PATH"
      return 1
    fi
  fi
  case "$reader" in
    python3) fields=$(_plan_read_python "$plan") ;;
    jq) fields=$(_plan_read_jq "$plan") ;;
    *) _plan_error "$plan" "HDRD_PLAN_READER=$reader: expected python3 or jq"; return 1 ;;
  esac
  case "$fields" in
    "error: "*) _plan_error "$plan" "${fields#error: }"; return 1 ;;
  esac
  { read -r PLAN_SHARDS; read -r PLAN_FRAMES; IFS= read -r PLAN_WORK_DIR; } <<<"$fields"
  PLAN_PATH=$(cd "$(dirname "$plan")" && pwd)/$(basename "$plan")
  case "$PLAN_WORK_DIR" in
    /*) ;;
    *) PLAN_WORK_DIR=$(dirname "$PLAN_PATH")/$PLAN_WORK_DIR ;;
  esac
}

_plan_error() { echo "${prog:+$prog: }plan $1: $2" >&2; }

# Both readers apply the same rules and print shards, frames and work_dir on three lines,
# or one line "error: WHAT".
_plan_read_python() {
  python3 - "$1" <<'PY'
import json, sys
path = sys.argv[1]
def fail(what):
    print(f"error: {what}")
    sys.exit(0)
try:
    with open(path, encoding="utf-8") as f:
        plan = json.load(f)
except (OSError, UnicodeDecodeError, json.JSONDecodeError):
    fail("not a JSON file")
if not isinstance(plan, dict):
    fail("not a JSON object")
if plan.get("format") != "hdrd-sequence-plan":
    fail(f"format is {json.dumps(plan.get('format'))}, expected \"hdrd-sequence-plan\"")
v = plan.get("shards")
if not isinstance(v, int) or isinstance(v, bool) or not 1 <= v <= 1000000:
    fail(f"shards is {json.dumps(v)}, expected an integer from 1 to 1000000")
v = plan.get("frames")
if not isinstance(v, int) or isinstance(v, bool) or v < 1:
    fail(f"frames is {json.dumps(v)}, expected an integer >= 1")
w = plan.get("work_dir")
if not isinstance(w, str) or not w or "\n" in w or "\0" in w:
    fail(f"work_dir is {json.dumps(w)}, expected a path")
print(plan["shards"], plan["frames"], w, sep="\n")
PY
}

_plan_read_jq() {
  jq -r '
    def check(ok; what): if ok then . else error(what) end;
    try (
      check(type == "object"; "not a JSON object")
      | check(.format == "hdrd-sequence-plan"; "format is \(.format | tojson), expected \"hdrd-sequence-plan\"")
      | check((.shards | type) == "number" and .shards == (.shards | floor) and .shards >= 1 and .shards <= 1000000; "shards is \(.shards | tojson), expected an integer from 1 to 1000000")
      | check((.frames | type) == "number" and .frames == (.frames | floor) and .frames >= 1; "frames is \(.frames | tojson), expected an integer >= 1")
      | check((.work_dir | type) == "string" and .work_dir != "" and (.work_dir | test("[\n\u0000]") | not); "work_dir is \(.work_dir | tojson), expected a path")
      | "\(.shards)\n\(.frames)\n\(.work_dir)"
    ) catch "error: \(.)"' "$1" 2>/dev/null || echo "error: not a JSON file"
}
