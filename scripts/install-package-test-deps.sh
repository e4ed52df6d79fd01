#!/usr/bin/env bash
# Installs what packaging and its tests (tests/package, docs/packaging.md) need and the
# build does not: debhelper (scripts/make-deb.sh), lintian, debootstrap (the Debian 12 test
# root), groff-base and man-db (the man page check) and podman for scripts/make-image.sh.
# Test-only: scripts/install-deps.sh does not install these. Debian 12 packages; needs root
# (or sudo); installs only what is missing.
set -euo pipefail
packages=(debhelper lintian debootstrap groff-base man-db podman)
# shellcheck source=scripts/lib/apt-missing.sh
source "$(dirname "${BASH_SOURCE[0]}")/lib/apt-missing.sh"
apt_install_missing install-package-test-deps "${packages[@]}"
