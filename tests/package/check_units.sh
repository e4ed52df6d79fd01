#!/usr/bin/env bash
# The installed units' hardening against what the daemon does with the installed
# configuration, read from an installed tree ROOT (a DESTDIR, or the package test's root):
# the dump directory writable under ProtectSystem=strict, the DRM devices allowed (a
# DeviceAllow= closes every device it does not name, and a directory such as /dev/dri names
# none), AF_UNIX allowed, the socket's group the configuration's socket_group, and the
# service running the installed program with the installed configuration.
# Usage: check_units.sh ROOT PREFIX UNITDIR   (e.g. / /usr /usr/lib/systemd/system)
set -euo pipefail
root=$1 prefix=$2 unitdir=$3
fail() { echo "FAIL: $*" >&2; exit 1; }
svc="$root$unitdir/hdrd.service"
etc=/etc
[ "$prefix" = /usr ] || etc=$prefix/etc
toml="$root$etc/hdrd/hdrd.toml"
[ -f "$svc" ] && [ -f "$root$unitdir/hdrd.socket" ] || fail "no hdrd.service and hdrd.socket in $root$unitdir"
[ -f "$toml" ] || fail "no $etc/hdrd/hdrd.toml in $root"
prop() { sed -n "s/^$1=//p" "$svc"; }
[ "$(prop ExecStart)" = "$prefix/bin/hdrd serve --config $etc/hdrd/hdrd.toml" ] ||
  fail "hdrd.service runs '$(prop ExecStart)', not $prefix/bin/hdrd with $etc/hdrd/hdrd.toml"
dump_dir=$(sed -n 's/^dump_dir = "\(.*\)"$/\1/p' "$toml")
[ -n "$dump_dir" ] || fail "the installed hdrd.toml sets no dump_dir"
writable=$(prop ReadWritePaths; prop StateDirectory | sed 's|^|/var/lib/|')
echo "$writable" | while read -r w; do case "$dump_dir/" in "$w"/*) echo ok ;; esac; done | grep -q ok ||
  fail "the dump directory $dump_dir is not writable under ProtectSystem=$(prop ProtectSystem) (writable: $writable)"
prop DeviceAllow | grep -qE '^(char-drm|/dev/dri/[^ ]+) rw' || fail "DeviceAllow=$(prop DeviceAllow) does not allow the DRM devices"
prop RestrictAddressFamilies | grep -qw AF_UNIX || fail "RestrictAddressFamilies forbids the Unix socket"
sock_group=$(sed -n 's/^SocketGroup=//p' "$root$unitdir/hdrd.socket")
[ "$sock_group" = "$(sed -n 's/^socket_group = "\(.*\)"$/\1/p' "$toml")" ] ||
  fail "hdrd.socket's SocketGroup=$sock_group is not the installed hdrd.toml's socket_group"
[ "$(sed -n 's/^ListenStream=//p' "$root$unitdir/hdrd.socket")" = "$(sed -n 's/^socket_path = "\(.*\)"$/\1/p' "$toml")" ] ||
  fail "hdrd.socket's ListenStream= is not the installed hdrd.toml's socket_path"
echo "ok: the units' hardening allows the dump directory $dump_dir, the DRM devices and the socket" >&2
