#!/usr/bin/env bash
# cmake --install into a DESTDIR, for the prefix /usr and for another one: the files of
# docs/packaging.md are where it says, the unit's paths follow the prefix given at install
# time, and the units' hardening fits the installed configuration (check_units.sh).
# Usage: install_test.sh BUILD_DIR
set -euo pipefail
build=$1
here=$(cd "$(dirname "$0")" && pwd)
fail() { echo "FAIL: $*" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
DESTDIR=$tmp/usr-root cmake --install "$build" --prefix /usr >/dev/null
r=$tmp/usr-root
for f in usr/bin/hdrd usr/bin/hdrctl usr/lib/sysusers.d/hdrd.conf usr/lib/tmpfiles.d/hdrd.conf etc/hdrd/hdrd.toml \
    usr/share/man/man1/hdrd.1 usr/share/man/man1/hdrctl.1 usr/share/man/man5/hdrd.toml.5 \
    usr/share/bash-completion/completions/hdrd usr/share/bash-completion/completions/hdrctl \
    usr/share/doc/hdrd/README.md usr/share/doc/hdrd/docs/api.md usr/share/doc/hdrd/docs/img/bt2111-pq.png \
    usr/lib/python3/dist-packages/hdrd_client.py; do
  [ -e "$r/$f" ] || fail "cmake --install --prefix /usr did not install /$f"
done
"$r/usr/bin/hdrd" serve --config "$r/etc/hdrd/hdrd.toml" --print-config >/dev/null ||
  fail "the installed hdrd.toml does not load"
bash "$here/check_units.sh" "$r" /usr /usr/lib/systemd/system
DESTDIR=$tmp/opt-root cmake --install "$build" --prefix /opt/hdrd >/dev/null
bash "$here/check_units.sh" "$tmp/opt-root" /opt/hdrd /opt/hdrd/lib/systemd/system
