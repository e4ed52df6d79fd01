#!/usr/bin/env bash
# The OCI image of scripts/make-image.sh (docs/packaging.md): its root filesystem (Debian
# packages only: the .deb installed into a Debian 12 minbase root) has hdrd and the hdrd
# user and no apt lists, and, run in a chroot as hdrd, `hdrd --version` and a 64x64 render
# work. Then, where podman runs here, the imported image hdrd:VERSION: entrypoint hdrd, user
# hdrd, `podman run hdrd:VERSION --version` and a 64x64 render; where it does not, that part
# skips (77) with podman's reason, the root filesystem checked all the same.
# Usage: image_test.sh BUILD_DIR
set -euo pipefail
build_dir=$(cd "${1:?usage: image_test.sh BUILD_DIR}" && pwd)
src=$(cd "$(dirname "$0")/../.." && pwd)
skip() { echo "SKIP: $*" >&2; exit 77; }
fail() { echo "FAIL: $*" >&2; exit 1; }
[ "$(id -u)" -eq 0 ] || skip "needs root (debootstrap and chroot)"
for tool in debootstrap dh dpkg-shlibdeps chroot; do
  command -v "$tool" >/dev/null || skip "$tool is missing: scripts/install-package-test-deps.sh installs the package test's tools"
done
version=$(sed -n 's/^project(hdrd VERSION \([0-9.]*\).*/\1/p' "$src/CMakeLists.txt")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$src"
deb=$(BUILD_DIR="$build_dir" LINTIAN=0 bash scripts/make-deb.sh | tail -1)
bash scripts/make-image.sh --deb "$deb" --rootfs-only "$work/rootfs.tar" ||
  skip "the root filesystem could not be built (no network to Debian's mirror?)"
echo "root filesystem: $(( $(stat -c %s "$work/rootfs.tar") / 1048576 )) MiB" >&2
mkdir "$work/root"
tar -C "$work/root" -xf "$work/rootfs.tar"
root=$work/root
[ -x "$root/usr/bin/hdrd" ] || fail "no /usr/bin/hdrd in the image"
grep -q '^hdrd:' "$root/etc/passwd" || fail "no hdrd user in the image"
[ -z "$(ls -A "$root/var/lib/apt/lists" 2>/dev/null)" ] || fail "apt's lists are in the image"
as_hdrd() { chroot "$root" /usr/bin/env -i PATH=/usr/bin:/usr/sbin EGL_PLATFORM=surfaceless /usr/sbin/runuser -u hdrd -- "$@"; }
got=$(as_hdrd hdrd --version)
[ "$got" = "$version" ] || fail "hdrd --version in the image gave '$got', not $version"
as_hdrd hdrd render --width 64 --height 64 --mode sdr --format png -o /tmp/frame -q >&2 || fail "a 64x64 render in the image failed"
[ "$(od -An -tx1 -j16 -N8 "$root/tmp/frame.png" | tr -d ' \n')" = "0000004000000040" ] || fail "the image's render is not a 64x64 PNG"

command -v podman >/dev/null || skip "root filesystem checked; podman is missing (scripts/install-package-test-deps.sh)"
why=$(podman info 2>&1 >/dev/null) || skip "root filesystem checked; podman cannot run here: $(tail -1 <<<"$why")"
image=$(bash scripts/make-image.sh --from-rootfs "$work/rootfs.tar" | tail -1)
[ "$image" = "hdrd:$version" ] || fail "make-image.sh tagged '$image', not hdrd:$version"
[ "$(podman image inspect --format '{{.Config.User}}' "$image")" = hdrd ] || fail "the image does not run as hdrd"
podman image inspect --format '{{json .Config.Entrypoint}}' "$image" | grep -q '"/usr/bin/hdrd"' || fail "the entrypoint is not hdrd"
if ! out=$(podman run --rm --network=none "$image" --version 2>&1); then
  case "$out" in
    *cgroup*|*namespace*|*"not permitted"*|*newuidmap*|*pivot_root*|*mount*) skip "root filesystem and image checked; podman run cannot start a container here: $(tail -1 <<<"$out")" ;;
    *) fail "podman run $image --version: $out" ;;
  esac
fi
[ "$(tail -1 <<<"$out")" = "$version" ] || fail "podman run $image --version gave '$out'"
podman run --rm --network=none "$image" render --width 64 --height 64 --mode sdr --format png -o /tmp/frame -q ||
  fail "a 64x64 render in the container failed"
echo "ok: $image, $(( $(podman image inspect --format '{{.Size}}' "$image") / 1048576 )) MiB" >&2
