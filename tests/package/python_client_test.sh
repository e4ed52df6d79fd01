#!/usr/bin/env bash
# clients/python installs offline with plain `pip install` (its build backend needs nothing
# from an index), the module imports from the install, and its version is hdrd's.
# Usage: python_client_test.sh SOURCE_DIR VERSION
set -euo pipefail
src=$1 version=$2
python=$(command -v python3) || { echo "SKIP: no python3" >&2; exit 77; }
"$python" -m pip --version >/dev/null 2>&1 || { echo "SKIP: no pip for $python (apt-get install python3-pip)" >&2; exit 77; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cp -r "$src/clients/python" "$tmp/src"  # pip may write into the tree; the checkout stays as it is
PIP_NO_INDEX=1 PIP_DISABLE_PIP_VERSION_CHECK=1 "$python" -m pip install -q --target "$tmp/site" "$tmp/src" ||
  { echo "FAIL: pip install clients/python without an index" >&2; exit 1; }
got=$(cd "$tmp" && PYTHONPATH="$tmp/site" "$python" -c 'import hdrd_client, os; print(hdrd_client.__version__, os.path.dirname(hdrd_client.__file__))')
[ "$got" = "$version $tmp/site" ] || { echo "FAIL: imported [$got], expected version $version from $tmp/site" >&2; exit 1; }
echo "ok: pip installed hdrd_client $version offline" >&2
