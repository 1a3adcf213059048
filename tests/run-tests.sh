#!/bin/sh
# Runs test programs: exit 0 = pass, 77 = skipped (with a printed reason),
# anything else = failure.  Usage: run-tests.sh BUILD_DIR TEST...
build=$1
shift
pass=0 fail=0 skip=0 failed=""
: "${MOCAP_TEST_TIMEOUT:=600}"
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=0}"
export LSAN_OPTIONS="${LSAN_OPTIONS:-suppressions=$(pwd)/tests/lsan.supp:print_suppressions=0}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
for t in "$@"; do
	name=$(basename "$t")
	log="$build/tests/$name.log"
	start=$(date +%s)
	timeout "$MOCAP_TEST_TIMEOUT" "$t" >"$log" 2>&1
	rc=$?
	secs=$(( $(date +%s) - start ))
	case $rc in
	0) pass=$((pass + 1)); echo "PASS $name (${secs}s)" ;;
	77) skip=$((skip + 1)); echo "SKIP $name: $(grep -i 'skip' "$log" | tail -n 1)" ;;
	*) fail=$((fail + 1)); failed="$failed $name"; echo "FAIL $name (exit $rc, ${secs}s)"; tail -n 30 "$log" | sed 's/^/    /' ;;
	esac
done
echo "$pass passed, $fail failed, $skip skipped"
[ "$fail" -eq 0 ] || { echo "failed:$failed"; exit 1; }
