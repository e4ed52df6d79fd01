#!/usr/bin/env bash
# The main job: install what is missing, build hdrd (only what the job needs), and produce
# frames for every display mode into ./out (a fixture EXR through the encoder; the built-in
# scene once rendered).
set -euo pipefail
cd "$(dirname "$0")"
bash scripts/build.sh hdrd
exec bash scripts/main-job.sh "$@"
