#!/usr/bin/env bash
# The generated man pages and bash completions (cmake/Docs.cmake) against their sources,
# read independently of the generator: every request setting's flag (`hdrd settings
# --json`) in hdrd(1), hdrctl(1) and the completions of the subcommands it applies to;
# every configuration key (`hdrd serve --print-config`) in hdrd.toml(5). Each page renders
# without a warning (groff -ww, and man -l); the completion scripts pass bash -n, and
# driving them as bash does (COMP_WORDS, COMP_CWORD) completes `hdrd render --mode ` to the
# modes, subcommands, flags, a comma list and file names.
# Usage: docs_test.sh BUILD_DIR
set -euo pipefail
build=$(cd "${1:?usage: docs_test.sh BUILD_DIR}" && pwd)
docs=$build/generated-docs
hdrd=$build/tools/hdrd
hdrctl=$build/tools/hdrctl/hdrctl
fail() { echo "FAIL: $*" >&2; exit 1; }
command -v python3 >/dev/null || { echo "SKIP: python3 is missing (it reads the JSON)" >&2; exit 77; }
command -v groff >/dev/null || { echo "SKIP: groff is missing (scripts/install-package-test-deps.sh)" >&2; exit 77; }

for page in hdrd.1 hdrctl.1 hdrd.toml.5; do
  [ -s "$docs/$page" ] || fail "$docs/$page is missing (target hdrd_docs)"
  warnings=$(groff -ww -mandoc -Tutf8 -z "$docs/$page" 2>&1)
  [ -z "$warnings" ] || fail "groff warns on $page: $warnings"
  if command -v man >/dev/null; then
    warnings=$(MANWIDTH=100 man --warnings -l "$docs/$page" 2>&1 >/dev/null)
    [ -z "$warnings" ] || fail "man -l warns on $page: $warnings"
  fi
done

settings=$("$hdrd" settings --json)
config=$("$hdrd" serve --config /dev/null --print-config 2>/dev/null || "$hdrd" serve --print-config)

# Flags, as roff spells them in the pages (\-\-peak).
roff_flag() { printf '%s' "$1" | sed 's/-/\\-/g'; }
missing=0
while IFS=$'\t' read -r flag reach sources; do
  if [ "$reach" != daemon ]; then
    grep -qF "\\fB$(roff_flag "$flag")\\fR" "$docs/hdrd.1" || { echo "hdrd.1 lacks $flag" >&2; missing=1; }
  fi
  if [ "$reach" != cli ]; then
    grep -qF "\\fB$(roff_flag "$flag")\\fR" "$docs/hdrctl.1" || { echo "hdrctl.1 lacks $flag" >&2; missing=1; }
  fi
  for s in $sources; do
    if [ "$reach" != daemon ]; then
      got=$(bash -c '. "$1"; _hdrd_flags "$2"; echo " $REPLY "' _ "$docs/hdrd.bash" "$s")
      [[ $got == *" $flag "* ]] || { echo "hdrd's completion of '$s' lacks $flag" >&2; missing=1; }
    fi
  done
done < <(python3 -c 'import json, sys
for s in json.load(sys.stdin):
    if s.get("cli"): print(s["cli"], s.get("reach", "everywhere"), " ".join(s["applies_to"]), sep="\t")' <<<"$settings")
while read -r key; do
  section=${key%%.*} name=${key#*.}
  grep -qF "\\fB$(printf '%s' "$name" | sed 's/-/\\-/g') = " "$docs/hdrd.toml.5" || { echo "hdrd.toml.5 lacks $key" >&2; missing=1; }
  grep -qF ".SS \"[$section]\"" "$docs/hdrd.toml.5" || { echo "hdrd.toml.5 lacks [$section]" >&2; missing=1; }
done < <(python3 -c 'import json, sys
for section, keys in json.load(sys.stdin).items():
    if isinstance(keys, dict): print("\n".join(section + "." + k for k in keys))' <<<"$config")
[ "$missing" -eq 0 ] || fail "a setting or configuration key is missing from the generated pages"

for c in hdrd hdrctl; do bash -n "$docs/$c.bash" || fail "bash -n $c.bash"; done
# complete WORDS...: what the completion function offers for the last word (as bash calls it).
complete_words() {
  local script=$1 fn=$2; shift 2
  bash -c '. "$1"; fn=$2; shift 2; COMP_WORDS=("$@"); COMP_CWORD=$(( $# - 1 )); COMP_LINE="$*"; "$fn"; printf "%s\n" "${COMPREPLY[@]}"' \
    _ "$script" "$fn" "$@" | sort
}
modes=$(python3 -c 'import json, sys
print("\n".join(c for s in json.load(sys.stdin) if s["path"] == "display.mode" for c in s["choices"]))' <<<"$settings" | sort)
[ -n "$modes" ] || fail "no display.mode choices in hdrd settings --json"
got=$(complete_words "$docs/hdrd.bash" _hdrd hdrd render --mode '')
[ "$got" = "$modes" ] || fail "hdrd render --mode <TAB> gave [$got], not the modes [$modes]"
got=$(complete_words "$docs/hdrctl.bash" _hdrctl hdrctl render --mode h)
[ "$got" = "$(grep '^h' <<<"$modes")" ] || fail "hdrctl render --mode h<TAB> gave [$got]"
[ "$(complete_words "$docs/hdrd.bash" _hdrd hdrd ren)" = render ] || fail "hdrd ren<TAB> is not render"
[ "$(complete_words "$docs/hdrd.bash" _hdrd hdrd sequence pl)" = plan ] || fail "hdrd sequence pl<TAB> is not plan"
got=$(complete_words "$docs/hdrd.bash" _hdrd hdrd render --mode sdr --peak-pe)
[ "$got" = --peak-percentile ] || fail "hdrd render --mode sdr --peak-pe<TAB> gave [$got]"
got=$(complete_words "$docs/hdrd.bash" _hdrd hdrd encode --format png,ex)
[ "$got" = png,exr ] || fail "hdrd encode --format png,ex<TAB> gave [$got] (a comma list)"
got=$(complete_words "$docs/hdrd.bash" _hdrd hdrd render --tonemap bt23)
[[ $got == *bt2390* ]] || fail "hdrd render --tonemap bt23<TAB> gave [$got] (the tone curves)"
got=$(complete_words "$docs/hdrd.bash" _hdrd hdrd render --peak '')
[ -z "$got" ] || fail "hdrd render --peak <TAB> offered [$got] for a number"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
touch "$tmp/Desk.exr"
got=$(cd "$tmp" && complete_words "$docs/hdrd.bash" _hdrd hdrd encode De)
[ "$got" = Desk.exr ] || fail "hdrd encode De<TAB> gave [$got], not the file"
got=$(cd "$tmp" && complete_words "$docs/hdrd.bash" _hdrd hdrd render --scene '' | tr '\n' ' ')
[[ $got == *material-grid* && $got == *Desk.exr* ]] || fail "hdrd render --scene <TAB> gave [$got] (scenes and files)"
echo "ok: man pages render cleanly and hold every setting and key; completions drive" >&2
