#!/usr/bin/env bash
# The fuzzing budget (docs/benchmarks.md "Fuzzing budget"), run by hand: builds the libFuzzer
# targets (the `fuzz` preset: clang, ASan + UBSan + libFuzzer), runs each one for RUNS
# executions pinned to one core, and prints a table: executions, wall and CPU seconds,
# executions per CPU second, coverage (edges) and features at the start and at the end, and
# findings (crashers are written as OUT/<target>-crash-*; with a fix they belong in
# fuzz/corpus/<target>/, which the normal tests replay).
#
# Usage: scripts/fuzz-budget.sh [--runs N] [--core C] [--out DIR] [--summary-only] [TARGET...]
#   TARGET: codec_core serial_to_device serial_from_device tcp_to_sim tcp_from_sim script
#           robot_config companion firmware_commands (default: all of them)
#   --runs N        executions per target (default 10000000)
#   --core C        the core to pin each run to (default 1)
#   --out DIR       new inputs and logs (default /tmp/scaratwin-fuzz); the saved corpus in
#                   fuzz/corpus/ is only read
#   --summary-only  print the table from the logs in DIR without running anything
set -euo pipefail
cd "$(dirname "$0")/.."
all=(codec_core serial_to_device serial_from_device tcp_to_sim tcp_from_sim script robot_config
  companion firmware_commands)
runs=10000000
core=1
out=/tmp/scaratwin-fuzz
summary_only=0
targets=()
while (($#)); do
  case $1 in
    --runs) runs=$2; shift 2 ;;
    --core) core=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --summary-only) summary_only=1; shift ;;
    -h|--help) sed -n '2,17p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "fuzz-budget: unknown option '$1' (see --help)" >&2; exit 2 ;;
    *)
      if [[ " ${all[*]} " != *" $1 "* ]]; then
        echo "fuzz-budget: no target '$1' (targets: ${all[*]})" >&2
        exit 2
      fi
      targets+=("$1"); shift ;;
  esac
done
((${#targets[@]})) || targets=("${all[@]}")
if ! [[ $runs =~ ^[1-9][0-9]*$ ]]; then
  echo "fuzz-budget: --runs '$runs': expected a positive whole number" >&2
  exit 2
fi
if ! [[ $core =~ ^[0-9]+$ ]] || ((core >= $(nproc))); then
  echo "fuzz-budget: --core '$core': this machine has cores 0..$(($(nproc) - 1))" >&2
  exit 2
fi
mkdir -p "$out"

if ((!summary_only)); then
  cmake --preset fuzz >/dev/null
  cmake --build --preset fuzz --target "${targets[@]/#/fuzz_}"
  for t in "${targets[@]}"; do
    mkdir -p "$out/$t"
    log=$out/$t.log
    echo "fuzz_$t: $runs executions on core $core (log: $log)"
    {
      echo "start $(date -u +%FT%TZ) load $(cut -d' ' -f1-3 /proc/loadavg)"
      rc=0
      /usr/bin/time -v taskset -c "$core" "build/fuzz/bin/fuzz_$t" "$out/$t" "fuzz/corpus/$t" \
        -runs="$runs" -print_final_stats=1 -artifact_prefix="$out/$t-" 2>&1 || rc=$?
      echo "end $(date -u +%FT%TZ) rc $rc load $(cut -d' ' -f1-3 /proc/loadavg)"
    } >"$log" 2>&1
  done
fi

# the table, from the logs
echo
echo "| target | executions | wall s | CPU s | executions per CPU s | cov / ft at start | cov / ft at end | findings |"
echo "|---|---|---|---|---|---|---|---|"
status=0
for t in "${targets[@]}"; do
  log=$out/$t.log
  if [[ ! -f $log ]]; then
    echo "| \`fuzz_$t\` | not run | | | | | | |"
    continue
  fi
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  wall=$(sed -n 's/^Done [0-9]* runs in \([0-9]*\) second.*/\1/p' "$log" | tail -1)
  cpu=$(sed -n 's/.*User time (seconds): *//p' "$log" | tail -1)
  start=$(grep -m1 -o 'INITED cov: [0-9]* ft: [0-9]*' "$log" | awk '{print $3 " / " $5}')
  end=$(grep -o 'cov: [0-9]* ft: [0-9]*' "$log" | tail -1 | awk '{print $2 " / " $4}')
  # crash-, leak-, timeout- and oom- files are findings; a slow-unit- file is an input that
  # took over 10 s of wall time (a paused or loaded run makes them: replay it to tell)
  crashes=$(find "$out" -maxdepth 1 -name "$t-*" ! -name "$t-slow-unit-*" | wc -l)
  slow=$(find "$out" -maxdepth 1 -name "$t-slow-unit-*" | wc -l)
  rc=$(sed -n 's/^end .* rc \([0-9]*\) .*/\1/p' "$log" | tail -1)
  if [[ -z $execs ]]; then
    execs="unfinished"
  fi
  per_cpu=""
  if [[ -n $cpu && $execs =~ ^[0-9]+$ ]]; then
    per_cpu=$(awk -v e="$execs" -v c="$cpu" 'BEGIN { if (c > 0) printf "%d", e / c }')
  fi
  findings="none"
  if ((crashes)) || [[ -n $rc && $rc != 0 ]]; then
    findings="$crashes file(s) in $out, exit $rc"
    status=1
  fi
  if ((slow)); then findings+=" ($slow slow unit(s) in $out)"; fi
  echo "| \`fuzz_$t\` | $execs | ${wall:-} | ${cpu:-} | $per_cpu | ${start:-} | ${end:-} | $findings |"
done
exit $status
