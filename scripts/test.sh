#!/usr/bin/env bash
# Installs what is missing, builds with sanitizers and -Werror, and runs every test (the package
# test installs the Debian packages on this machine: CI is root); then checks
# that CMake's default generator (Unix Makefiles, the presets use Ninja) builds the parts with
# custom build steps: the browser page (npm ci), the generated firmware header and the firmware
# (SCARATWIN_TEST_MAKE=0 skips that check). Between the two: coverage (scripts/coverage.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
jobs=$(nproc)
cmake --preset ci
cmake --build --preset ci -j "$jobs"
# a suite that is no longer registered (a missing component, a CMake condition gone wrong)
# must not pass as "100% tests passed": the count may only grow past the floor kept in the
# repository (raise it when you add tests)
registered=$(ctest --preset ci -N | sed -n 's/^Total Tests: //p')
floor=$(grep -v '^#' tests/minimum_test_count | tr -d '[:space:]')
if [[ -z "$registered" || "$registered" -lt "$floor" ]]; then
  echo "error: ${registered:-no} tests registered, fewer than the ${floor} of" \
    "tests/minimum_test_count: a suite dropped out (see the configure warnings)" >&2
  exit 1
fi
echo "tests registered: $registered (floor $floor)"
# the package test installs the .debs on this machine: CI runs as root, so it must not skip
export SCARATWIN_PACKAGE_TEST=required
# long runs (label `long`: more builds to calibrate, ...) are run by hand, docs/calibration.md
ctest --preset ci -j "$jobs" -LE long
# line and branch coverage of the pure core and the firmware's modules against their floors
# (docs/coverage.md; SCARATWIN_TEST_COVERAGE=0 skips it)
if [[ "${SCARATWIN_TEST_COVERAGE:-1}" != 0 ]]; then
  scripts/coverage.sh
fi
if [[ "${SCARATWIN_TEST_MAKE:-1}" != 0 ]]; then
  cmake -S . -B build/ci-make -G "Unix Makefiles" -DSCARATWIN_BUILD_TESTS=OFF \
    -DSCARATWIN_BUILD_BENCH=OFF -DSCARATWIN_WERROR=ON
  cmake --build build/ci-make -j "$jobs" --target scaratwin_web_assets firmware
fi
