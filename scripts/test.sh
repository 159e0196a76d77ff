#!/usr/bin/env bash
# Installs what is missing, builds with sanitizers and -Werror, and runs every test; then checks
# that CMake's default generator (Unix Makefiles, the presets use Ninja) builds the parts with
# custom build steps: the browser page (npm ci), the generated firmware header and the firmware
# (SCARATWIN_TEST_MAKE=0 skips that check).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
jobs=$(nproc)
cmake --preset ci
cmake --build --preset ci -j "$jobs"
ctest --preset ci -j "$jobs"
if [[ "${SCARATWIN_TEST_MAKE:-1}" != 0 ]]; then
  cmake -S . -B build/ci-make -G "Unix Makefiles" -DSCARATWIN_BUILD_TESTS=OFF \
    -DSCARATWIN_BUILD_BENCH=OFF -DSCARATWIN_WERROR=ON
  cmake --build build/ci-make -j "$jobs" --target scaratwin_web_assets firmware
fi
