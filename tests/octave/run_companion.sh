#!/usr/bin/env bash
# Runs one GNU Octave test of the companion dialects against a live process, as a user would:
#   run_companion.sh sim   OCTAVE TEST_DIR OUT_DIR SCARATWIN_SIM
#   run_companion.sh robot OCTAVE TEST_DIR OUT_DIR SCARATWIN_ROBOT FIRMWARE_ELF
# It starts the simulator (any free ports, companion dialect on) or the emulated robot (exact
# plant, unpaced), reads the ports it prints, runs the Octave script and stops the process.
set -euo pipefail
kind=$1 octave=$2 test_dir=$3 out_dir=$4 exe=$5
mkdir -p "$out_dir"
log="$out_dir/companion_$kind.log"
pid=
cleanup() { [[ -n $pid ]] && kill "$pid" 2>/dev/null && wait "$pid" 2>/dev/null; true; }
trap cleanup EXIT

if [[ $kind == sim ]]; then
  "$exe" --port 0 --companion-port 0 --http-port 0 >"$log" 2>&1 &
  pid=$!
  want='companion dialect on'
else
  "$exe" --firmware "$6" --speed 1 --plant ideal --side-port 0 --camera-port -1 >"$log" 2>&1 &
  pid=$!
  want='side channel:'
fi
for _ in $(seq 1 300); do
  grep -q "$want" "$log" && break
  kill -0 "$pid" 2>/dev/null || { cat "$log"; echo "the $kind process ended"; exit 1; }
  sleep 0.1
done
grep -q "$want" "$log" || { cat "$log"; echo "the $kind process did not start"; exit 1; }

cd "$test_dir"
rc=0
if [[ $kind == sim ]]; then
  v1=$(sed -n 's/.*listening on [0-9.]*:\([0-9]*\).*/\1/p' "$log")
  companion=$(sed -n 's/.*companion dialect on [0-9.]*:\([0-9]*\).*/\1/p' "$log")
  "$octave" --quiet --no-gui companion_sim_test.m "$companion" "$v1" "$out_dir" || rc=$?
else
  pty=$(sed -n 's/^pty: \(.*\)$/\1/p' "$log")
  side=$(sed -n 's/^side channel: [0-9.]*:\([0-9]*\).*/\1/p' "$log")
  "$octave" --quiet --no-gui companion_robot_test.m "$pty" "$side" || rc=$?
fi
echo "--- $kind log ---"
cat "$log"
exit $rc
