#!/usr/bin/env bash
# Installs what is missing, builds with sanitizers and -Werror, and runs every test (the package
# test installs the Debian packages on this machine: CI is root); checks that CMake's default
# generator (Unix Makefiles, the presets use Ninja) builds the parts with custom build steps:
# the browser page (npm ci), the generated firmware header and the firmware
# (SCARATWIN_TEST_MAKE=0 skips that check); coverage (scripts/coverage.sh); and the transports,
# channels, web server and hub under ThreadSanitizer (SCARATWIN_TEST_TSAN=0 skips them).
# CI has two cores and most suites run alone, paced to the wall clock, leaving a core free:
# the demo's test runs beside the end of the build; coverage, the Makefile build and the
# ThreadSanitizer build beside the suites, each extra job at idle priority (chrt --idle).
set -euo pipefail
cd "$(dirname "$0")/.."
# where the time goes (CI's budget is 40 minutes on two cores): each phase's end in seconds
# since the start, printed at the end of the run
phases=()
mark() { phases+=("$(printf '%6d s  %s' "$SECONDS" "$1")"); }
SECONDS=0
scripts/install-deps.sh
mark "installed what was missing"
jobs=$(nproc)
cmake --preset ci
mark "configured"
mkdir -p build
# what failed; the run goes on to the end, so that one CI run tells about everything
failures=()
# The names of the tests that failed in a ctest run (its build directory), on one line.
failed_tests() {
  sed 's/^[0-9]*://' "$1/Testing/Temporary/LastTestsFailed.log" 2>/dev/null | paste -sd ' ' ||
    true
}
# The last lines of each failed test's output (from ctest's LastTest.log), kept for the end of
# the run, where a truncated log still shows them.
failed_outputs=build/failed-tests.log
save_failed_output() {
  local dir=$1 names
  names=$(failed_tests "$dir")
  [[ -n "$names" ]] || return 0
  awk -v names=" $names " '
    / Testing: / { name = $NF; keep = index(names, " " name " ") > 0; n = 0; next }
    keep && /^Test (Passed|Failed)|^<end of output>/ {
      printf "---- output of %s (its last %d lines)\n", name, n
      for (i = 1; i <= n; ++i) print buf[i]
      keep = 0; next
    }
    keep { if (n == 40) { for (i = 1; i < 40; ++i) buf[i] = buf[i + 1]; n = 39 } buf[++n] = $0 }
  ' "$dir/Testing/Temporary/LastTest.log" >>"$failed_outputs" 2>/dev/null || true
}
rm -f "$failed_outputs"
# Waits for a job started beside the main work, prints its log, and notes a failure.
collect() {
  local name=$1 pid=$2 log=$3 rc=0
  wait "$pid" || rc=$?
  echo "---- $name (run beside the main work; log: $log)"
  cat "$log"
  if [[ $rc != 0 ]]; then failures+=("$name: exit $rc, log $log"); fi
}
# The demo's end-to-end test, the longest suite (about 5 minutes, paced to the wall clock and
# run alone), starts as soon as what it runs is built; the rest of the build goes on beside it
# under SCHED_IDLE (chrt --idle), so the demo's processes always get the CPU first.
first_test='^Demo\.SortsEveryCubeAndRecordsTheTwin$'
first_log=build/first-test.log
# (the firmware is no build dependency of the test: the emulator loads it when it starts)
cmake --build --preset ci -j "$jobs" --target test_demo firmware
mark "built the demo's test and the firmware"
set -m  # its own process group: an interrupted run stops all of it
ctest --preset ci --no-tests=error -R "$first_test" >"$first_log" 2>&1 &
first_pid=$!
set +m
trap 'kill -- "-$first_pid" 2>/dev/null || true' EXIT
chrt --idle 0 cmake --build --preset ci -j "$jobs"
mark "built the rest (beside the demo's test)"
collect "the demo's test" "$first_pid" "$first_log"
mark "the demo's test ended"
trap - EXIT
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

# Coverage (scripts/coverage.sh) and the Makefile build of the parts with custom build steps
# run in the background while the suites run: most suites are paced to the wall clock and run
# alone (RUN_SERIAL), using under one of the two cores on average. The background job runs
# under SCHED_IDLE (chrt --idle), so the scheduler gives any suite's process the CPU first;
# its output goes to a log, printed once the suites are done.
background_log=build/background-checks.log
background() {
  set -euo pipefail
  # line and branch coverage of the pure core and the firmware's modules against their floors
  # (docs/coverage.md; SCARATWIN_TEST_COVERAGE=0 skips it)
  if [[ "${SCARATWIN_TEST_COVERAGE:-1}" != 0 ]]; then
    scripts/coverage.sh
    echo "coverage done at $SECONDS s"
  fi
  # CMake's default generator (Unix Makefiles) builds the browser page and the firmware
  # (SCARATWIN_TEST_MAKE=0 skips it)
  if [[ "${SCARATWIN_TEST_MAKE:-1}" != 0 ]]; then
    cmake -S . -B build/ci-make -G "Unix Makefiles" -DSCARATWIN_BUILD_TESTS=OFF \
      -DSCARATWIN_BUILD_BENCH=OFF -DSCARATWIN_WERROR=ON
    cmake --build build/ci-make -j "$jobs" --target scaratwin_web_assets firmware
    echo "Makefile build done at $SECONDS s"
  fi
  # ThreadSanitizer build of the transports and channels, the web server and the hub (the
  # `tsan` preset); their tests run after the suites (SCARATWIN_TEST_TSAN=0 skips both). The
  # hub's tests start the ci build's simulator and emulated robot (SCARATWIN_TEST_PEERS_DIR):
  # the hub is checked in the test's own process. docs/benchmarks.md has the hand-run set,
  # which adds those programs and the fault matrix built with ThreadSanitizer.
  if [[ "${SCARATWIN_TEST_TSAN:-1}" != 0 ]]; then
    cmake --preset tsan -DSCARATWIN_TEST_PEERS_DIR="$PWD/build/ci/bin" >/dev/null
    cmake --build --preset tsan -j "$jobs" --target test_transport test_statements test_web \
      test_fake_robot test_hub_robots
    echo "ThreadSanitizer build done at $SECONDS s"
  fi
}
# its own process group (set -m), so that an interrupted run stops all of it
set -m
(
  chrt --idle -p 0 "$BASHPID" >/dev/null
  background
) >"$background_log" 2>&1 &
background_pid=$!
set +m
trap 'kill -- "-$background_pid" 2>/dev/null || true' EXIT

# long runs (label `long`: more builds to calibrate, ...) are run by hand, docs/calibration.md
suites=0
ctest --preset ci -j "$jobs" -LE long -E "$first_test" || suites=$?
mark "the suites ended"
if [[ $suites != 0 ]]; then
  # name the failed tests at the end, where a truncated log still shows them
  failed_list=$(failed_tests build/ci)
  save_failed_output build/ci
  failures+=("the test suites: ctest exit $suites; failed: ${failed_list:-(see the log)}")
fi

collect "coverage, the Makefile build and the ThreadSanitizer build" "$background_pid" \
  "$background_log"
mark "coverage, the Makefile build and the ThreadSanitizer build ended (beside the suites)"
trap - EXIT
# the transports and channels, the web server and the hub under ThreadSanitizer (the preset
# sets TSAN_OPTIONS: halt_on_error=1, so a report fails its test); the hub's tests with a real
# simulator run alone (RUN_SERIAL)
if [[ "${SCARATWIN_TEST_TSAN:-1}" != 0 ]]; then
  tsan_suites='LineSplitter|Tcp|IoThread|Serial|SequenceTracker|LinkCounters|Statements|Channel'
  tsan_suites+='|WebServer|HttpTest|Feed|Commands|FakeRobotTest|FakeRobotHub|HubRobots|TwinDbThreads'
  # as for the suites: the count may not fall below the floor kept in the repository
  tsan_registered=$(ctest --preset tsan -N -R "^(${tsan_suites})\\." | sed -n 's/^Total Tests: //p')
  tsan_floor=$(grep -v '^#' tests/minimum_tsan_test_count | tr -d '[:space:]')
  if [[ -z "$tsan_registered" || "$tsan_registered" -lt "$tsan_floor" ]]; then
    failures+=("ThreadSanitizer: ${tsan_registered:-no} tests registered, fewer than the\
 ${tsan_floor} of tests/minimum_tsan_test_count (a suite dropped out of the tsan build)")
  fi
  echo "ThreadSanitizer tests registered: ${tsan_registered:-0} (floor $tsan_floor)"
  if ! ctest --preset tsan --no-tests=error -j "$jobs" -R "^(${tsan_suites})\\."; then
    failed_list=$(failed_tests build/tsan)
    save_failed_output build/tsan
    failures+=("the ThreadSanitizer tests of the transports, the web server and the hub;\
 failed: ${failed_list:-(see the log)}")
  fi
fi
mark "the ThreadSanitizer tests ended"
echo "---- where the time went (seconds since the start, at the end of each phase)"
printf '%s\n' "${phases[@]}"
if ((${#failures[@]})); then
  if [[ -s "$failed_outputs" ]]; then cat "$failed_outputs" >&2; fi
  printf 'error: %s\n' "${failures[@]}" >&2
  exit 1
fi
