#!/usr/bin/env bash
# Line and branch coverage of the pure core (kinematics, trajectory, protocol) and of the
# firmware's host-built modules, with gcov and gcovr: builds the unit tests with the coverage
# preset (build/coverage), runs them, writes the report (build/coverage/report/index.html) and
# checks each module against its floor (scripts/coverage_check.py; docs/coverage.md).
# Installs nothing: run scripts/install-deps.sh first (scripts/test.sh does).
set -euo pipefail
cd "$(dirname "$0")/.."
build=build/coverage
jobs=$(nproc)
# the unit tests of the modules measured (the end-to-end suites need the sanitizer build)
tests=(test_core test_protocol test_calibration test_plant test_vision test_webcam test_firmware
  test_fleet_topics)

cmake --preset coverage >/dev/null
cmake --build --preset coverage -j "$jobs" --target "${tests[@]}"
find "$build" -name '*.gcda' -delete
for t in "${tests[@]}"; do
  echo "coverage: $t"
  "$build/bin/$t" --gtest_brief=1 >"$build/$t.log" 2>&1 ||
    { tail -40 "$build/$t.log"; echo "error: $t failed (log: $build/$t.log)" >&2; exit 1; }
done
rm -rf "$build/report"
mkdir -p "$build/report"
# exceptions' unwinding edges and branches the compiler proves dead are not branches of ours
gcovr -r . "$build" -j "$jobs" \
  --filter 'src/(kinematics|trajectory|protocol|calibration|config|plant|vision)/' \
  --filter 'src/fleet/(topics|fleet_watch)\.' \
  --filter 'firmware/src/' \
  --exclude-unreachable-branches --exclude-throw-branches \
  --json-summary "$build/report/summary.json" \
  --html-details "$build/report/index.html"
python3 scripts/coverage_check.py "$build/report/summary.json"
echo "coverage report: $build/report/index.html"
