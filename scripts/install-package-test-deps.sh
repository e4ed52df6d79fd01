#!/usr/bin/env bash
# Installs what packaging and its tests (tests/package, docs/packaging.md) need and the
# build does not: debhelper (scripts/make-deb.sh), lintian, debootstrap (the Debian 12 test
# root), groff-base and man-db (the man page check) and podman for scripts/make-image.sh.
# Test-only: scripts/install-deps.sh does not install these. Debian 12 packages; needs root
# (or sudo); installs only what is missing.
set -euo pipefail
packages=(debhelper lintian debootstrap groff-base man-db podman)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q '^install ok installed' || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0
echo "install-package-test-deps: installing ${missing[*]}" >&2
sudo=""
[ "$(id -u)" -eq 0 ] || sudo=sudo
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >&2
