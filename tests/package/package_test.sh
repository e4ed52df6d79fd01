#!/usr/bin/env bash
# The Debian package as an administrator meets it (docs/packaging.md): builds the .deb
# (scripts/make-deb.sh, lintian clean), installs it with apt-get into a fresh Debian 12
# minbase root so that its Depends come from Debian, then, without systemd:
#  - the hdrd user, its directories, the conffile and the enabled socket (not the service);
#  - systemd-analyze verify on the installed units, and that their hardening still lets
#    the daemon write its dump directory, open /dev/dri and serve its socket;
#  - `hdrd serve --config /etc/hdrd/hdrd.toml` as hdrd; hdrctl renders a 64x64 frame and a
#    dump through /run/hdrd/hdrd.sock as a member of the socket's group; a third user cannot
#    connect;
#  - purge removes what the package made and keeps the dumps; HDRD_PURGE_DUMPS=yes removes them.
# The root is debootstrap'ed once and kept as a tarball, and apt's downloads are kept, in
# $HDRD_PACKAGE_CACHE (default ~/.cache/hdrd). Needs root (chroot, mounts), debootstrap,
# debhelper and lintian (scripts/install-package-test-deps.sh) and Debian's mirror; skips
# (77) with the reason otherwise.
# Usage: package_test.sh BUILD_DIR
set -euo pipefail
build_dir=$(cd "${1:?usage: package_test.sh BUILD_DIR}" && pwd)
src=$(cd "$(dirname "$0")/../.." && pwd)
skip() { echo "SKIP: $*" >&2; exit 77; }
fail() { echo "FAIL: $*" >&2; exit 1; }
step() { echo "== $* ($(( $(date +%s) - t0 )) s)" >&2; }
t0=$(date +%s)

[ "$(id -u)" -eq 0 ] || skip "needs root (chroot and mounts for the Debian 12 test root)"
for tool in debootstrap dh lintian dpkg-shlibdeps chroot mount; do
  command -v "$tool" >/dev/null || skip "$tool is missing: scripts/install-package-test-deps.sh installs the package test's tools"
done
cache=${HDRD_PACKAGE_CACHE:-$HOME/.cache/hdrd}
mkdir -p "$cache/apt-archives/partial"
mirror=$(awk '/^URIs:/ {print $2; exit}' /etc/apt/sources.list.d/debian.sources 2>/dev/null || true)
mirror=${mirror:-http://deb.debian.org/debian}

step "building the package"
deb=$(cd "$src" && BUILD_DIR="$build_dir" bash scripts/make-deb.sh | tail -1)
deb="$src/$deb"
[ -f "$deb" ] || fail "scripts/make-deb.sh wrote no .deb"
dpkg-deb -f "$deb" Depends | grep -q 'libc6' || fail "Depends has no shared libraries (dpkg-shlibdeps): $(dpkg-deb -f "$deb" Depends)"

tarball="$cache/bookworm-minbase.tar"
if [ ! -f "$tarball" ]; then
  step "debootstrap --variant=minbase bookworm (once; kept in $tarball)"
  fresh=$(mktemp -d)
  debootstrap --variant=minbase bookworm "$fresh/root" "$mirror" >"$fresh/debootstrap.log" 2>&1 ||
    { tail -20 "$fresh/debootstrap.log" >&2; rm -rf "$fresh"; skip "debootstrap failed (no network to $mirror?)"; }
  tar -C "$fresh/root" -cf "$tarball.tmp" . && mv "$tarball.tmp" "$tarball"
  rm -rf "$fresh"
fi

work=$(mktemp -d)
root="$work/root"
daemon_pid=""
cleanup() {
  [ -n "$daemon_pid" ] && kill "$daemon_pid" 2>/dev/null && wait "$daemon_pid" 2>/dev/null
  for m in var/cache/apt/archives dev/pts dev proc; do
    mountpoint -q "$root/$m" 2>/dev/null && umount -l "$root/$m"
  done
  rm -rf "$work"
}
trap cleanup EXIT
mkdir "$root"
tar -C "$root" -xf "$tarball"
chmod 755 "$root"  # mktemp -d is 0700: nobody but root could run anything in it
mount -t proc proc "$root/proc"
mount --bind /dev "$root/dev"
mount --bind "$cache/apt-archives" "$root/var/cache/apt/archives"
# The root's apt sources are this machine's own.
rm -f "$root/etc/apt/sources.list"
cp /etc/apt/sources.list.d/*.sources "$root/etc/apt/sources.list.d/" 2>/dev/null || cp /etc/apt/sources.list "$root/etc/apt/"
in_root() { chroot "$root" /usr/bin/env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin LANG=C.UTF-8 "$@"; }
as_user() { local u=$1; shift; in_root /usr/sbin/runuser -u "$u" -- "$@"; }

step "apt-get install ./$(basename "$deb")"
cp "$deb" "$root/tmp/"
in_root apt-get update -qq >&2 || skip "apt-get update failed in the test root (no network to the mirror?)"
in_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -q "./tmp/$(basename "$deb")" >"$work/install.log" 2>&1 ||
  { tail -30 "$work/install.log" >&2; fail "apt-get install of the package failed"; }

step "what the package made"
in_root getent passwd hdrd >/dev/null || fail "no hdrd user"
in_root id -nG hdrd | tr ' ' '\n' | grep -qx video || fail "hdrd is not in the video group: $(in_root id -nG hdrd)"
[ "$(in_root stat -c '%U:%G %a' /var/lib/hdrd/dumps)" = "hdrd:hdrd 750" ] ||
  fail "/var/lib/hdrd/dumps is $(in_root stat -c '%U:%G %a' /var/lib/hdrd/dumps), not hdrd:hdrd 750"
[ "$(in_root stat -c '%U:%G %a' /run/hdrd)" = "hdrd:hdrd 750" ] || fail "/run/hdrd is $(in_root stat -c '%U:%G %a' /run/hdrd)"
in_root dpkg-query -W -f='${Conffiles}\n' hdrd | grep -q '^ /etc/hdrd/hdrd.toml ' || fail "/etc/hdrd/hdrd.toml is not a conffile"
[ -L "$root/etc/systemd/system/sockets.target.wants/hdrd.socket" ] || fail "hdrd.socket is not enabled"
[ ! -e "$root/etc/systemd/system/multi-user.target.wants/hdrd.service" ] || fail "hdrd.service is enabled (the socket starts it)"
unitdir=/usr/lib/systemd/system
for page in hdrd.1 hdrctl.1; do [ -f "$root/usr/share/man/man1/$page.gz" ] || fail "no man page $page"; done
[ -f "$root/usr/share/man/man5/hdrd.toml.5.gz" ] || fail "no man page hdrd.toml.5"
[ -f "$root/usr/share/bash-completion/completions/hdrd" ] || fail "no bash completion for hdrd"
[ -f "$root/usr/share/doc/hdrd/docs/api.md" ] || fail "no docs under /usr/share/doc/hdrd"
[ -f "$root/usr/lib/python3/dist-packages/hdrd_client.py" ] || fail "no Python client module"

step "systemd-analyze verify and the units' hardening"
# --man=no: the root has no man-db to look the man: links up; the pages are checked above.
in_root systemd-analyze verify --man=no "$unitdir/hdrd.socket" "$unitdir/hdrd.service" >"$work/verify.log" 2>&1 ||
  { cat "$work/verify.log" >&2; fail "systemd-analyze verify failed"; }
if grep -v -e 'Failed to .* cgroup' -e 'Not running as root' "$work/verify.log" | grep -q .; then
  cat "$work/verify.log" >&2
  fail "systemd-analyze verify warned"
fi
bash "$src/tests/package/check_units.sh" "$root" /usr "$unitdir"
dump_dir=$(sed -n 's/^dump_dir = "\(.*\)"$/\1/p' "$root/etc/hdrd/hdrd.toml")

step "hdrd serve as hdrd, hdrctl as a member of the hdrd group"
in_root useradd -m -G hdrd alice
in_root useradd -m bob
chroot "$root" /usr/bin/env -i PATH=/usr/sbin:/usr/bin LANG=C.UTF-8 EGL_PLATFORM=surfaceless \
  /usr/sbin/runuser -u hdrd -- hdrd serve --config /etc/hdrd/hdrd.toml >"$work/serve.log" 2>&1 &
daemon_pid=$!
for _ in $(seq 100); do
  [ -S "$root/run/hdrd/hdrd.sock" ] && break
  kill -0 "$daemon_pid" 2>/dev/null || { cat "$work/serve.log" >&2; fail "hdrd serve exited"; }
  sleep 0.2
done
[ -S "$root/run/hdrd/hdrd.sock" ] || { cat "$work/serve.log" >&2; fail "no socket /run/hdrd/hdrd.sock after 20 s"; }
[ "$(in_root stat -c '%U:%G %a' /run/hdrd/hdrd.sock)" = "hdrd:hdrd 660" ] ||
  fail "the socket is $(in_root stat -c '%U:%G %a' /run/hdrd/hdrd.sock), not hdrd:hdrd 660"
as_user alice hdrctl render --width 64 --height 64 --mode sdr -o /tmp/frame.png >&2 ||
  { cat "$work/serve.log" >&2; fail "hdrctl render as alice (group hdrd) failed"; }
# PNG signature, then IHDR's width and height (big-endian) at bytes 16..23.
[ "$(od -An -tx1 -N8 "$root/tmp/frame.png" | tr -d ' \n')" = "89504e470d0a1a0a" ] || fail "frame.png is no PNG"
[ "$(od -An -tx1 -j16 -N8 "$root/tmp/frame.png" | tr -d ' \n')" = "0000004000000040" ] || fail "frame.png is not 64x64"
as_user alice hdrctl render --width 64 --height 64 --mode sdr --dump --name kept >/dev/null ||
  fail "a dump request failed (the dump directory)"
[ "$(in_root stat -c %U "$dump_dir/kept.png")" = hdrd ] || fail "the dump $dump_dir/kept.png was not written by hdrd"
set +e
as_user bob hdrctl status >"$work/bob.log" 2>&1
rc=$?
set -e
[ "$rc" -eq 3 ] || { cat "$work/bob.log" >&2; fail "bob (not in the hdrd group) got exit status $rc from hdrctl status, not 3"; }
grep -qi "permission denied" "$work/bob.log" || { cat "$work/bob.log" >&2; fail "bob's refusal does not say permission denied"; }
kill "$daemon_pid"
wait "$daemon_pid" || true
daemon_pid=""

step "purge keeps the dumps"
in_root apt-get purge -y -q hdrd >"$work/purge.log" 2>&1 || { cat "$work/purge.log" >&2; fail "purge failed"; }
for gone in /usr/bin/hdrd /etc/hdrd /run/hdrd /etc/systemd/system/sockets.target.wants/hdrd.socket \
    /usr/lib/systemd/system/hdrd.service /usr/share/doc/hdrd; do
  [ ! -e "$root$gone" ] && [ ! -L "$root$gone" ] || fail "purge left $gone"
done
[ -f "$root$dump_dir/kept.png" ] || fail "purge removed the user's dumps"
left=$(cd "$root/var/lib/hdrd" && ls -A)
[ "$left" = dumps ] || fail "purge left in /var/lib/hdrd: $left"
in_root dpkg-query -W -f='${db:Status-Abbrev}' hdrd 2>/dev/null | grep -q '^ii' && fail "hdrd is still installed"

step "HDRD_PURGE_DUMPS=yes purges the dumps too"
in_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -q "./tmp/$(basename "$deb")" >"$work/install2.log" 2>&1 ||
  { tail -30 "$work/install2.log" >&2; fail "reinstall failed"; }
[ -f "$root$dump_dir/kept.png" ] || fail "reinstall lost the kept dumps"
in_root env HDRD_PURGE_DUMPS=yes apt-get purge -y -q hdrd >"$work/purge2.log" 2>&1 || { cat "$work/purge2.log" >&2; fail "purge failed"; }
[ ! -e "$root/var/lib/hdrd" ] || fail "HDRD_PURGE_DUMPS=yes left /var/lib/hdrd"

step "passed"
