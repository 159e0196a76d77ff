#!/usr/bin/env bash
# Installs what is missing, builds what the demo needs (release preset) and runs the main job.
# Arguments go to `scaratwin demo` (e.g. --serial /dev/ttyACM0, --out DIR, --keep-open).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
cmake --preset release
cmake --build --preset release -j "$(nproc)" --target scaratwin scaratwin-sim scaratwin-robot \
  firmware scaratwin_web_assets
exec build/release/bin/scaratwin demo "$@"
