#!/bin/sh
# `make install` into a temporary PREFIX (its own BUILD folder, so that the
# paths compiled into the programs are the install's, as for a package),
# then the installed programs run from elsewhere: mocapd with no plugin_dir
# finds the installed plugins, tracks the bundled demo clip with the
# installed rig and model; mocap-bench finds the installed model; then
# `make uninstall` removes what was installed and keeps the config.
# Usage: tests/install-test.sh (from the repository root).
set -u
repo=$(pwd)
tmp=$(mktemp -d /tmp/mocap-install-XXXXXX)
prefix=$tmp/usr
vars="BUILD=build-install PREFIX=$prefix SYSCONFDIR=$tmp/etc"
fail() { echo "FAIL: $*"; exit 1; }
cleanup() { rm -rf "$tmp"; }
trap cleanup EXIT

make -s $vars install >"$tmp/install.log" 2>&1 || { tail -n 30 "$tmp/install.log"; fail "make install"; }
for f in bin/mocapd bin/mocapctl bin/mocap-bench lib/mocapd/drivers/mocap-driver-files.so \
	share/mocapd/models/default.json share/mocapd/rigs/ego_stereo.json lib/libmocap.so.1; do
	[ -e "$prefix/$f" ] || fail "$prefix/$f was not installed"
done
[ -e "$tmp/etc/mocapd/mocapd.conf" ] || fail "no $tmp/etc/mocapd/mocapd.conf"
if command -v scdoc >/dev/null; then
	for m in man8/mocapd.8 man5/mocapd.conf.5 man1/mocapctl.1 man1/mocap-bench.1; do
		[ -s "$prefix/share/man/$m" ] || fail "no man page $prefix/share/man/$m"
	done
fi
grep -q "$prefix/share/mocapd" "$tmp/etc/mocapd/mocapd.conf" || fail "the installed config does not name $prefix/share/mocapd"
grep -q "plugin_dir = $prefix/lib/mocapd/drivers" "$tmp/etc/mocapd/mocapd.conf" || fail "the installed config does not name $prefix/lib/mocapd/drivers"

# bash completion of mocapctl, from the install
comp=$prefix/share/bash-completion/completions/mocapctl
[ -e "$comp" ] || fail "no $comp"
got=$(bash -c ". '$comp'; COMP_WORDS=(mocapctl sta); COMP_CWORD=1; _mocapctl; echo \${COMPREPLY[*]}")
[ "$got" = status ] || fail "completing 'mocapctl sta' gave '$got'"

# mocapd: no plugin_dir in the config, so the compiled-in one must be the install's
for cam in left right; do
	printf '[camera %s]\ndriver = files\nrig_camera = %s\npath = %s\ncount = 8\nrate = 30\n' \
		"$cam" "$cam" "$repo/tests/data/ego_demo/$cam"
done >"$tmp/demo.conf"
cat >>"$tmp/demo.conf" <<CONF
[tracker]
rig = $prefix/share/mocapd/rigs/ego_stereo.json
model = $prefix/share/mocapd/models/default.json
init_joints = $repo/tests/data/ego_demo/gt.json
[socket]
path = $tmp/mocapd.sock
CONF
cd "$tmp" || fail "cd $tmp"
"$prefix/bin/mocapd" --config "$tmp/demo.conf" --check >"$tmp/check.log" 2>&1 || { cat "$tmp/check.log"; fail "installed mocapd --check"; }
timeout 120 "$prefix/bin/mocapd" --config "$tmp/demo.conf" --print --exit-at-end >"$tmp/run.log" 2>&1
rc=$?
grep -q "$prefix/lib/mocapd/drivers/mocap-driver-files.so" "$tmp/run.log" || { cat "$tmp/run.log"; fail "the installed mocapd did not load $prefix/lib/mocapd/drivers"; }
if grep -qi "opencl" "$tmp/run.log" && grep -q "error" "$tmp/run.log" && [ $rc -ne 0 ]; then
	echo "SKIP: the installed mocapd runs, but no usable OpenCL device here to track"
	exit 77
fi
[ $rc -eq 0 ] || { tail -n 30 "$tmp/run.log"; fail "installed mocapd exited $rc"; }
n=$(grep -c "^frame .* ok " "$tmp/run.log")
[ "$n" -ge 3 ] || { tail -n 30 "$tmp/run.log"; fail "installed mocapd tracked $n frame sets"; }
echo "installed mocapd: $n frame sets tracked with $prefix/lib/mocapd/drivers"

# mocap-bench from another folder: the installed model
"$prefix/bin/mocap-bench" --clip "$repo/tests/data/ego_demo" --frames 3 --no-thesis --reference-frames 0 --quiet \
	>"$tmp/bench.log" 2>&1 || { cat "$tmp/bench.log"; fail "installed mocap-bench"; }
grep -q "^RESULT clip=ego_demo frames=3" "$tmp/bench.log" || { cat "$tmp/bench.log"; fail "no RESULT line"; }
echo "installed mocap-bench: $(grep '^RESULT' "$tmp/bench.log")"

cd "$repo" || fail "cd $repo"
make -s $vars uninstall >"$tmp/uninstall.log" 2>&1 || { cat "$tmp/uninstall.log"; fail "make uninstall"; }
for f in bin/mocapd bin/mocap-bench lib/mocapd share/mocapd lib/libmocap.so.1 share/man/man8/mocapd.8; do
	[ ! -e "$prefix/$f" ] || fail "make uninstall left $prefix/$f"
done
[ -e "$tmp/etc/mocapd/mocapd.conf" ] || fail "make uninstall removed the config"
echo "PASS: install, run from the install, uninstall"
