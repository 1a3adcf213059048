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
. "$repo/tests/lib/installed-demo.sh"
cleanup() { rm -rf "$tmp"; }
trap cleanup EXIT

make -s $vars install >"$tmp/install.log" 2>&1 || { tail -n 30 "$tmp/install.log"; fail "make install"; }
# the linker's cache: ldconfig run (as root), or the user told to (issue 31 item 5)
grep -q "^ldconfig: done\|run 'sudo ldconfig'" "$tmp/install.log" || fail "make install neither ran ldconfig nor said to"
grep -q "$prefix/lib is not in the linker's search path" "$tmp/install.log" || fail "make install did not say $prefix/lib is not searched"
for f in bin/mocapd bin/mocapctl bin/mocap-bench bin/mocap-vmc bin/mocap-export bin/mocap-track bin/mocap-calibrate \
	bin/mocap-graph bin/mocap-preview share/mocapd/preview/index.html \
	lib/mocapd/drivers/mocap-driver-take.so lib/mocapd/drivers/mocap-driver-files.so \
	share/mocapd/models/default.json share/mocapd/rigs/ego_stereo.json lib/libmocap.so.1; do
	[ -e "$prefix/$f" ] || fail "$prefix/$f was not installed"
done
[ -e "$tmp/etc/mocapd/mocapd.conf" ] || fail "no $tmp/etc/mocapd/mocapd.conf"
[ -e "$tmp/etc/mocapd/vmc.conf" ] || fail "no $tmp/etc/mocapd/vmc.conf"
grep -q "^ExecStart=$prefix/bin/mocap-vmc .*--config $tmp/etc/mocapd/vmc.conf" "$prefix/lib/systemd/system/mocap-vmc.service" ||
	fail "the installed mocap-vmc.service does not run $prefix/bin/mocap-vmc with $tmp/etc/mocapd/vmc.conf"
"$prefix/bin/mocap-vmc" --config "$tmp/etc/mocapd/vmc.conf" --socket "$tmp/none.sock" >"$tmp/vmc.log" 2>&1
[ $? -eq 1 ] && grep -q "cannot connect to mocapd" "$tmp/vmc.log" || fail "installed mocap-vmc with the installed vmc.conf: $(cat "$tmp/vmc.log")"
if command -v scdoc >/dev/null; then
	for m in man8/mocapd.8 man5/mocapd.conf.5 man1/mocapctl.1 man1/mocap-bench.1 man1/mocap-vmc.1 man1/mocap-export.1 \
		man1/mocap-track.1 man1/mocap-calibrate.1 man1/mocap-graph.1 man1/mocap-preview.1; do
		[ -s "$prefix/share/man/$m" ] || fail "no man page $prefix/share/man/$m"
	done
fi
# every installed program: -h, --version, a bad option (issue 31 item 6)
"$repo/tests/cli-test.sh" "$prefix/bin" >"$tmp/cli.log" 2>&1 || { cat "$tmp/cli.log"; fail "tests/cli-test.sh $prefix/bin"; }
# mocap-calibrate from the install: a board to print
"$prefix/bin/mocap-calibrate" board --out "$tmp/board" >"$tmp/board.log" 2>&1 && [ -s "$tmp/board.pdf" ] && [ -s "$tmp/board.json" ] ||
	fail "installed mocap-calibrate board: $(cat "$tmp/board.log")"
grep -q "$prefix/share/mocapd" "$tmp/etc/mocapd/mocapd.conf" || fail "the installed config does not name $prefix/share/mocapd"
grep -q "plugin_dir = $prefix/lib/mocapd/drivers" "$tmp/etc/mocapd/mocapd.conf" || fail "the installed config does not name $prefix/lib/mocapd/drivers"

# mocap-preview with its compiled-in paths: the installed page and model;
# it serves the page while it waits for a daemon that is not there
"$prefix/bin/mocap-preview" --socket "$tmp/none.sock" --listen 127.0.0.1:0 >"$tmp/preview.log" 2>&1 &
preview=$!
i=0
while ! grep -q "serving http://127.0.0.1:" "$tmp/preview.log" && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
port=$(sed -n 's|.*serving http://127.0.0.1:\([0-9]*\)/.*|\1|p' "$tmp/preview.log")
page=$(/usr/bin/python3 -c "import urllib.request,sys; print(urllib.request.urlopen('http://127.0.0.1:$port/').read().decode())" 2>&1)
kill $preview
wait $preview
echo "$page" | grep -q 'id="plot"' || fail "installed mocap-preview did not serve the installed page: $page $(cat "$tmp/preview.log")"
! grep -q "no body model" "$tmp/preview.log" || fail "installed mocap-preview did not find the installed model: $(cat "$tmp/preview.log")"
grep -q "waiting for mocapd" "$tmp/preview.log" || fail "installed mocap-preview: $(cat "$tmp/preview.log")"

# bash completion of mocapctl, from the install
comp=$prefix/share/bash-completion/completions/mocapctl
[ -e "$comp" ] || fail "no $comp"
got=$(bash -c ". '$comp'; COMP_WORDS=(mocapctl sta); COMP_CWORD=1; _mocapctl; echo \${COMPREPLY[*]}")
[ "$got" = status ] || fail "completing 'mocapctl sta' gave '$got'"

# mocapd: no plugin_dir in the config, so the compiled-in one must be the install's
cd "$tmp" || fail "cd $tmp"
installed_demo "$prefix/bin/mocapd" "$prefix/share/mocapd" "$prefix/lib/mocapd/drivers"

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
