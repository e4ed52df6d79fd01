#!/usr/bin/env bash
# Builds hdrd and runs every test (unit, display-mode suite, end to end, fuzz corpora).
# Tests that need a GPU or ../shared skip with a message when it is missing.
set -euo pipefail
cd "$(dirname "$0")"
bash scripts/build.sh
cd "${BUILD_DIR:-build}"
ctest --output-on-failure -j "${JOBS:-$(nproc)}" --timeout 600 "$@"
