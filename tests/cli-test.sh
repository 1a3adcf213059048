#!/bin/sh
# cli-test.sh: one set of command-line conventions for every program
# (issue 31 item 6).  Each program in BINDIR (default $BUILD/bin, or the
# installed bin folder that tests/install-test.sh passes):
#   -h and --help: exit 0, a usage text on stdout;
#   -V and --version: exit 0, the program's name and a version on stdout;
#   a bad option: exit 2, a message on stderr.
# Also: a subcommand that does not exist is named as such (mocap-graph),
# mocapd(8) documents exit status 2.
# Usage: tests/cli-test.sh [BINDIR]
set -u
bindir=${1:-${MOCAP_BUILD:-build}/bin}
tmp=$(mktemp -d /tmp/mocap-cli-XXXXXX)
trap 'rm -rf "$tmp"' EXIT
failures=0 n=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

run() { # run PROG ARGS...: stdout in $tmp/out, stderr in $tmp/err, status in $rc
	timeout 20 "$@" >"$tmp/out" 2>"$tmp/err" </dev/null
	rc=$?
}

for prog in "$bindir"/*; do
	[ -f "$prog" ] && [ -x "$prog" ] || continue
	name=$(basename "$prog")
	n=$((n + 1))
	for h in -h --help; do
		run "$prog" $h
		[ $rc -eq 0 ] || fail "$name $h: exit $rc, not 0"
		grep -qi "usage" "$tmp/out" || fail "$name $h: no usage on stdout"
	done
	for v in -V --version; do
		run "$prog" $v
		[ $rc -eq 0 ] || fail "$name $v: exit $rc, not 0"
		grep -q "^$name .*[0-9]\.[0-9]" "$tmp/out" || fail "$name $v: stdout does not start with '$name' and a version: $(head -n 1 "$tmp/out")"
	done
	run "$prog" --no-such-option
	[ $rc -eq 2 ] || fail "$name --no-such-option: exit $rc, not 2"
	[ -s "$tmp/err" ] || fail "$name --no-such-option: nothing on stderr"
	echo "$name: -h, --help, -V, --version, a bad option: ok"
done
[ $n -gt 0 ] || { echo "FAIL: no programs in $bindir"; exit 1; }

if [ -x "$bindir/mocap-graph" ]; then
	run "$bindir/mocap-graph" bogus
	[ $rc -eq 2 ] && grep -q "'bogus' is not a command" "$tmp/err" ||
		fail "mocap-graph bogus: exit $rc, $(cat "$tmp/err")"
fi
man=$(dirname "$0")/../docs/man/mocapd.8.scd
[ ! -f "$man" ] || grep -q "^2 on a bad command line\|, 2 on a bad command line" "$man" ||
	fail "mocapd(8) does not document exit status 2"
# One version: mocapd's, the .deb's (debian/changelog), the Python
# package's and libmocap's (python3-mocap was 0.1 beside pip's 1.2.0).
repo=$(dirname "$0")/..
if [ -x "$bindir/mocapd" ] && [ -f "$repo/debian/changelog" ]; then
	v=$("$bindir/mocapd" --version | sed -n 's/^mocapd \([^ ]*\).*/\1/p')
	deb=$(sed -n '1s/^mocapd (\([^)-]*\).*/\1/p' "$repo/debian/changelog")
	py=$(sed -n 's/^__version__ = "\(.*\)"/\1/p' "$repo/python/mocap/__init__.py")
	so=$(sed -n 's/^IPC_SO_VERSION := //p' "$repo/ipc/module.mk")
	[ "$v" = "$deb" ] && [ "$v" = "$py" ] && [ "$v" = "$so" ] ||
		fail "versions differ: mocapd $v, debian/changelog $deb, python/mocap $py, libmocap $so"
fi
[ $failures -eq 0 ] || exit 1
echo "cli-test: $n programs ok"
