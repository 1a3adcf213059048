#!/bin/sh
# Runs one libFuzzer target with ASan+UBSan and leak detection, and prints
# one line: its executions, time and findings.  On a finding it prints the
# end of the log and fails.
#   run-fuzzer.sh NAME BINARY SEEDS WORKDIR [libFuzzer options...]
# WORKDIR/corpus keeps what the fuzzer found between runs, WORKDIR/NAME.log
# the whole log; a crashing input is saved as WORKDIR/crash-* (or leak-*,
# timeout-*, oom-*).  tests/fuzz/dict/NAME.dict is used when it exists.
name=$1 bin=$2 seeds=$3 work=$4
shift 4
mkdir -p "$work/corpus" || exit 1
log=$work/$name.log
dict=$(dirname "$0")/dict/$name.dict
[ -f "$dict" ] && set -- "-dict=$dict" "$@"
start=$(date +%s)
ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=0 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
	"$bin" -print_final_stats=1 -artifact_prefix="$work/" "$@" "$work/corpus" "$seeds" >"$log" 2>&1
rc=$?
secs=$(( $(date +%s) - start ))
runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
if [ $rc -ne 0 ]; then
	tail -n 60 "$log"
	echo "$name: FAILED (exit $rc) after ${runs:-?} executions in ${secs} s; log $log, input in $work/"
	exit 1
fi
units=$(ls "$work/corpus" | wc -l)
echo "$name: ${runs:-?} executions in ${secs} s, 0 findings (corpus $units inputs; log $log)"
