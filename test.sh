#!/usr/bin/env bash
# Builds hdrd and runs every test (unit, display-mode suite, end to end, fuzz corpora).
# Project code is built with warnings as errors, so it stays warning-free.
# Tests that need a GPU or ../shared skip with a message when it is missing. Opt-in suites:
# CMAKE_ARGS=-DHDRD_PACKAGE_TEST=ON ./test.sh adds the Debian package and image tests
# (docs/packaging.md; about 6 minutes more, root and Debian's mirror needed).
set -euo pipefail
cd "$(dirname "$0")"
CMAKE_ARGS="-DHDRD_WERROR=ON ${CMAKE_ARGS:-}" bash scripts/build.sh
cd "${BUILD_DIR:-build}"
ctest --output-on-failure -j "${JOBS:-$(nproc)}" --timeout 600 "$@"
