#!/usr/bin/env bash
# Opt-in end-to-end KMS test: boots Debian 12's own kernel under QEMU (software emulation,
# TCG) with the vkms module, runs vkms_check (hdrd's libdrm enumeration and KmsOutput:
# TEST_ONLY + commit of a frame), captures the CRTC through vkms's writeback connector and
# compares the pixels. See docs/vkms.md for why each step is needed.
#
# Usage: run_vkms_test.sh VKMS_CHECK_BINARY [CACHE_DIR]
# Exit: 0 pass, 1 fail, 77 skipped (no qemu, no network for the packages, ...).
# Needs: qemu-system-x86 (Debian), apt-get download access, make and gcc (kernel module
# build), ldd. Not root: nothing is installed, everything lands in CACHE_DIR.
set -euo pipefail

check_bin=${1:?usage: run_vkms_test.sh VKMS_CHECK_BINARY [CACHE_DIR]}
cache=${2:-${TMPDIR:-/tmp}/hdrd-vkms-cache}
check_bin=$(readlink -f "$check_bin")
skip() { echo "vkms test skipped: $*" >&2; exit 77; }

for tool in qemu-system-x86_64 apt-get apt-cache dpkg-deb make gcc ldd gzip; do
  command -v "$tool" >/dev/null 2>&1 || skip "$tool is not installed (qemu: apt-get install qemu-system-x86)"
done
[ -x "$check_bin" ] || skip "$check_bin is not built (configure with -DHDRD_VKMS_TEST=ON)"
mkdir -p "$cache"
cache=$(cd "$cache" && pwd)  # absolute: the headers' Makefile is rewritten to point into it
cd "$cache"

# 1. Debian 12's kernel and what an out-of-tree vkms build needs. The stock kernel is
#    built with "# CONFIG_DRM_VKMS is not set", so vkms comes from linux-source.
image=$(apt-cache depends linux-image-amd64 | awk '/Depends: linux-image-/ {print $2; exit}')
[ -n "$image" ] || skip "cannot resolve linux-image-amd64"
kver=${image#linux-image-}                      # e.g. 6.1.0-56-amd64
pkgver=$(apt-cache show "$image" | awk '/^Version:/ {print $2; exit}')
series=${kver%%-*}; series=${series%.*}         # 6.1
abi=${kver%-amd64}                              # 6.1.0-56
want=("$image=$pkgver" "linux-headers-$kver=$pkgver" "linux-headers-$abi-common=$pkgver"
      "linux-kbuild-$series=$pkgver" "linux-source-$series=$pkgver" busybox-static)
if [ ! -f "$kver.downloaded" ]; then
  echo "downloading ${want[*]} (about 220 MB, once)" >&2
  apt-get download "${want[@]}" >/dev/null 2>&1 || skip "apt-get download failed (no network?)"
  touch "$kver.downloaded"
fi

# 2. Unpack and build vkms.ko against the matching headers.
if [ ! -f "vkms-$kver/vkms.ko" ]; then
  rm -rf root && mkdir -p root
  for deb in "${image}"_*.deb linux-headers-"$kver"_*.deb linux-headers-"$abi"-common_*.deb \
             linux-kbuild-"$series"_*.deb linux-source-"$series"_*.deb busybox-static_*.deb; do
    dpkg-deb -x "$deb" root
  done
  hdr="$cache/root/usr/src/linux-headers-$kver"
  sed -i "s#/usr/src/#$cache/root/usr/src/#" "$hdr/Makefile"
  rm -rf "vkms-$kver" && mkdir "vkms-$kver"
  tar -xaf "root/usr/src/linux-source-$series.tar.xz" --strip-components=5 -C "vkms-$kver" \
      "linux-source-$series/drivers/gpu/drm/vkms"
  make -s -C "$hdr" M="$cache/vkms-$kver" CONFIG_DRM_VKMS=m modules >vkms-build.log 2>&1 \
      || { tail -20 vkms-build.log >&2; echo "vkms module build failed" >&2; exit 1; }
fi

# 3. An initramfs: busybox, the DRM modules, vkms_check and the shared libraries it uses.
rm -rf initramfs && mkdir -p initramfs/{bin,dev,proc,sys,mods,tmp}
cp root/bin/busybox initramfs/bin/
cp "$check_bin" initramfs/vkms_check
for lib in $(ldd "$check_bin" | grep -o '/[^ ]*'); do
  mkdir -p "initramfs$(dirname "$lib")"
  cp -L "$lib" "initramfs$lib"
done
mods="root/lib/modules/$kver/kernel/drivers/gpu/drm"
cp "$mods/drm.ko" "$mods/drm_kms_helper.ko" "$mods/drm_shmem_helper.ko" "vkms-$kver/vkms.ko" initramfs/mods/
cat >initramfs/init <<'EOF'
#!/bin/busybox sh
/bin/busybox --install -s /bin
mount -t proc proc /proc
mount -t sysfs sys /sys
mount -t devtmpfs dev /dev
for m in drm drm_kms_helper drm_shmem_helper; do insmod /mods/$m.ko || echo "insmod $m failed"; done
insmod /mods/vkms.ko enable_writeback=1 || echo "insmod vkms failed"
/vkms_check
echo "VKMS_EXIT $?"
poweroff -f
EOF
chmod +x initramfs/init
(cd initramfs && find . | ../root/bin/busybox cpio -o -H newc 2>/dev/null | gzip -1 >../initrd.gz)

# 4. Boot under TCG (software emulation: nested KVM was unreliable on the build VMs).
echo "booting $kver under qemu (TCG)" >&2
timeout 300 qemu-system-x86_64 -machine accel=tcg -cpu max -m 1024 -smp 1 \
    -kernel "root/boot/vmlinuz-$kver" -initrd initrd.gz \
    -append "console=ttyS0 loglevel=3 panic=-1" -nographic -no-reboot >vm.log 2>&1 || true
grep -E '^(ok  |FAIL|  )|VKMS_' vm.log | tr -d '\r' || true
grep -q "VKMS_CHECK PASS" vm.log
