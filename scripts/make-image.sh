#!/usr/bin/env bash
# Builds the OCI image hdrd:VERSION from Debian packages only, for the cluster
# (deploy/k8s defaults to it) and for `podman run` / `docker run`: a debootstrap'ed Debian 12
# minbase root (cached as a tarball, as the package test's), the .deb of scripts/make-deb.sh
# installed with apt-get (its Depends from Debian, no recommends; systemd-standalone-sysusers
# for the user, not systemd), apt's lists and caches
# and the docs dropped, then imported with `podman import`: no registry is pulled from.
# The entrypoint is hdrd, the user hdrd (created by the package). Prints the image's size.
#   scripts/make-image.sh [--deb FILE] [--rootfs-only OUT.tar | --from-rootfs ROOT.tar]
# --rootfs-only writes the root as a tarball and stops (what podman would import; the
# image test checks it where podman cannot run); --from-rootfs imports such a tarball.
# env: BUILD_DIR, HDRD_PACKAGE_CACHE.
set -euo pipefail
cd "$(dirname "$0")/.."
die() { echo "make-image: $*" >&2; exit 1; }
deb="" rootfs_only="" from_rootfs=""
while [ $# -gt 0 ]; do
  case "$1" in
    --deb) deb=$2; shift 2 ;;
    --rootfs-only) rootfs_only=$2; shift 2 ;;
    --from-rootfs) from_rootfs=$2; shift 2 ;;
    *) die "unknown option $1 (usage: scripts/make-image.sh [--deb FILE] [--rootfs-only OUT.tar])" ;;
  esac
done
version=$(sed -n 's/^project(hdrd VERSION \([0-9.]*\).*/\1/p' CMakeLists.txt)
# The image from a root filesystem tarball: entrypoint hdrd, user hdrd.
import_image() {
  podman import \
    --change 'ENTRYPOINT ["/usr/bin/hdrd"]' --change 'CMD ["--help"]' --change 'USER hdrd' \
    --change 'WORKDIR /var/lib/hdrd' --change 'ENV EGL_PLATFORM=surfaceless' \
    --change "LABEL org.opencontainers.image.version=$version org.opencontainers.image.title=hdrd" \
    "$1" "hdrd:$version" >&2
  local size
  size=$(podman image inspect --format '{{.Size}}' "hdrd:$version")
  echo "make-image: hdrd:$version, $(( size / 1048576 )) MiB (root filesystem $(( $(stat -c %s "$1") / 1048576 )) MiB)" >&2
  echo "hdrd:$version"
}
if [ -n "$from_rootfs" ]; then
  command -v podman >/dev/null || die "podman is missing (scripts/install-package-test-deps.sh)"
  import_image "$from_rootfs"
  exit 0
fi
[ "$(id -u)" -eq 0 ] || die "needs root (debootstrap and chroot)"
command -v debootstrap >/dev/null || die "debootstrap is missing (scripts/install-package-test-deps.sh)"
[ -n "$rootfs_only" ] || command -v podman >/dev/null || die "podman is missing (scripts/install-package-test-deps.sh)"
[ -n "$deb" ] || deb=$(bash scripts/make-deb.sh | tail -1)
[ -f "$deb" ] || die "no package $deb"
deb=$(cd "$(dirname "$deb")" && pwd)/$(basename "$deb")

cache=${HDRD_PACKAGE_CACHE:-$HOME/.cache/hdrd}
mkdir -p "$cache/apt-archives/partial"
mirror=$(awk '/^URIs:/ {print $2; exit}' /etc/apt/sources.list.d/debian.sources 2>/dev/null || true)
mirror=${mirror:-http://deb.debian.org/debian}
tarball="$cache/bookworm-minbase.tar"
if [ ! -f "$tarball" ]; then
  echo "make-image: debootstrap --variant=minbase bookworm (once; kept in $tarball)" >&2
  fresh=$(mktemp -d)
  debootstrap --variant=minbase bookworm "$fresh/root" "$mirror" >&2 || { rm -rf "$fresh"; die "debootstrap failed"; }
  tar -C "$fresh/root" -cf "$tarball.tmp" . && mv "$tarball.tmp" "$tarball"
  rm -rf "$fresh"
fi

work=$(mktemp -d)
root=$work/root
cleanup() {
  for m in var/cache/apt/archives dev proc; do mountpoint -q "$root/$m" 2>/dev/null && umount -l "$root/$m"; done
  rm -rf "$work"
}
trap cleanup EXIT
mkdir "$root"
tar -C "$root" -xf "$tarball"
chmod 755 "$root"
mount -t proc proc "$root/proc"
mount --bind /dev "$root/dev"
mount --bind "$cache/apt-archives" "$root/var/cache/apt/archives"
rm -f "$root/etc/apt/sources.list"
cp /etc/apt/sources.list.d/*.sources "$root/etc/apt/sources.list.d/" 2>/dev/null || cp /etc/apt/sources.list "$root/etc/apt/"
cp "$deb" "$root/tmp/"
in_root() { chroot "$root" /usr/bin/env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin LANG=C.UTF-8 DEBIAN_FRONTEND=noninteractive "$@"; }
in_root apt-get update -qq >&2
# systemd-standalone-sysusers meets the package's "systemd | systemd-standalone-sysusers"
# (the user is made on install) without systemd itself, which a container does not run.
in_root apt-get install -y -q --no-install-recommends "./tmp/$(basename "$deb")" systemd-standalone-sysusers >&2
rm -f "$root/tmp/$(basename "$deb")"
umount -l "$root/var/cache/apt/archives" "$root/dev" "$root/proc"
# What a container does not need: apt's lists, logs, docs and man pages (not hdrd's docs).
rm -rf "$root"/var/lib/apt/lists/* "$root"/var/log/*.log "$root"/var/log/apt/* "$root"/usr/share/man/*
find "$root/usr/share/doc" -mindepth 1 -maxdepth 1 ! -name hdrd -exec rm -rf {} +
# The dump directory for `podman run -v DIR:/var/lib/hdrd/dumps`, and the socket directory.
mkdir -p "$root/var/lib/hdrd/dumps" "$root/run/hdrd"
chroot "$root" chown hdrd:hdrd /var/lib/hdrd /var/lib/hdrd/dumps /run/hdrd
rootfs=$work/rootfs.tar
tar --numeric-owner -C "$root" -cf "$rootfs" .
if [ -n "$rootfs_only" ]; then
  mv "$rootfs" "$rootfs_only"
  echo "make-image: root filesystem $rootfs_only, $(( $(stat -c %s "$rootfs_only") / 1048576 )) MiB" >&2
  exit 0
fi
import_image "$rootfs"
