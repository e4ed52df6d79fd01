#!/usr/bin/env bash
# Builds dist/hdrd_VERSION_amd64.deb (and with HDRD_DBGSYM=1 its -dbgsym .deb) with debhelper from the
# project's build directory (debian/rules says why it is packed from there rather than
# compiled again): builds hdrd, hdrctl and the generated man pages and completions in it
# (nothing to do after ./test.sh), installs them into debian/hdrd and packs that. Then runs
# lintian on the .deb when lintian is installed (scripts/install-package-test-deps.sh).
# Usage: scripts/make-deb.sh            env: BUILD_DIR (default build), JOBS, LINTIAN=0 to skip
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${BUILD_DIR:-build}
for tool in dh dpkg-shlibdeps; do
  command -v "$tool" >/dev/null || { echo "make-deb: $tool is missing (apt-get install debhelper dpkg-dev)" >&2; exit 1; }
done
if [ ! -f "$build_dir/CMakeCache.txt" ]; then
  CMAKE_ARGS="-DHDRD_WERROR=ON ${CMAKE_ARGS:-}" BUILD_DIR="$build_dir" bash scripts/build.sh hdrd hdrctl
fi
version=$(dpkg-parsechangelog -S Version)
project_version=$(sed -n 's/^project(hdrd VERSION \([0-9.]*\).*/\1/p' CMakeLists.txt)
[ "$version" = "$project_version" ] || {
  echo "make-deb: debian/changelog says $version, CMakeLists.txt $project_version: add a changelog entry (dch -v $project_version)" >&2
  exit 1
}
mkdir -p dist
rm -f "dist/hdrd_${version}_amd64.deb" "dist/hdrd-dbgsym_${version}_amd64.deb"
# debian/rules binary is the packaging interface itself (Rules-Requires-Root: no, so no
# fakeroot); dpkg-buildpackage would add a .changes and .buildinfo in the parent directory.
# No -dbgsym package unless HDRD_DBGSYM=1: xz-compressing the RelWithDebInfo debug
# information (about 160 MB) costs minutes on 2 cores.
ddebs=noddebs
[ "${HDRD_DBGSYM:-0}" = 1 ] && ddebs=""
HDRD_BUILD_DIR="$build_dir" HDRD_JOBS="${JOBS:-$(nproc)}" DEB_BUILD_OPTIONS="${DEB_BUILD_OPTIONS:-} $ddebs" \
  debian/rules binary >&2
debian/rules clean >&2
deb="dist/hdrd_${version}_amd64.deb"
[ -f "$deb" ] || { echo "make-deb: $deb was not written" >&2; exit 1; }
if [ "${LINTIAN:-1}" != 0 ] && command -v lintian >/dev/null; then
  lintian --fail-on error,warning --info "$deb" >&2
fi
echo "$deb"
