#!/bin/sh
# tree-test.sh: programs run from the build tree find the tree's plugins and
# files, or fail at once naming the option to use (issue 31 item 8).
#  - mocapd --check on config/demo.conf and config/outside_demo.conf (the
#    bundled twin of outside.conf) passes without --plugin-dir;
#  - mocapd with a plugin_dir that does not exist fails before building the
#    OpenCL kernels, naming --plugin-dir;
#  - mocap-preview serves without --www.
# Run from the repository root, from another folder as cwd for the programs.
# MOCAP_BUILD names the build folder (default build).
set -u
repo=$(pwd)
build=$(cd "${MOCAP_BUILD:-build}" && pwd)
tmp=$(mktemp -d /tmp/mocap-tree-XXXXXX)
trap 'rm -rf "$tmp"' EXIT
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
cd "$tmp" || exit 1

for conf in demo.conf outside_demo.conf; do
	"$build/bin/mocapd" --check --config "$repo/config/$conf" >"$tmp/check.out" 2>&1 ||
		{ fail "mocapd --check config/$conf without --plugin-dir:"; cat "$tmp/check.out"; }
	grep -q "running from a build tree: driver plugins from $build/drivers" "$tmp/check.out" ||
		fail "config/$conf: mocapd did not say it took $build/drivers"
done

cat >"$tmp/missing.conf" <<CONF
[daemon]
plugin_dir = $tmp/no-such-dir
[camera left]
driver = files
rig_camera = left
path = $repo/tests/data/ego_demo/left
[tracker]
rig = $repo/config/rigs/ego_stereo.json
model = $repo/config/models/default.json
[socket]
path = $tmp/s.sock
CONF
start=$(date +%s)
"$build/bin/mocapd" --config "$tmp/missing.conf" >"$tmp/run.out" 2>&1
rc=$?
secs=$(( $(date +%s) - start ))
[ $rc -eq 1 ] || fail "mocapd with a missing plugin_dir: exit $rc, not 1"
grep -q "driver plugin directory $tmp/no-such-dir: No such file or directory; give one with --plugin-dir" "$tmp/run.out" ||
	{ fail "mocapd with a missing plugin_dir does not name --plugin-dir:"; cat "$tmp/run.out"; }
grep -q "tracker:" "$tmp/run.out" && fail "mocapd set up the tracker (OpenCL) before finding no plugin directory"
[ $secs -le 5 ] || fail "mocapd took $secs s to fail on a missing plugin directory"

timeout 3 "$build/bin/mocap-preview" --listen 127.0.0.1:0 --socket "$tmp/none.sock" >"$tmp/preview.out" 2>&1
grep -q "serving http://127.0.0.1:" "$tmp/preview.out" ||
	{ fail "mocap-preview from the build tree without --www:"; cat "$tmp/preview.out"; }

[ $failures -eq 0 ] || exit 1
echo "tree-test: ok"
