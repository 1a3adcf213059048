# Sourced by tests/install-test.sh and tests/package-test.sh: runs an
# installed mocapd on the bundled demo clip with the installed rig, model
# and plugins (no plugin_dir in the config: the compiled-in one must be the
# install's).  Needs fail() and the variables repo and tmp.
#
#   installed_demo MOCAPD DATADIR PLUGINDIR
#
# DATADIR holds rigs/ and models/.  Exits 77 (skip) when the daemon runs
# but there is no usable OpenCL device to track with.
installed_demo() {
	mocapd_bin=$1 data=$2 plugins=$3
	for cam in left right; do
		printf '[camera %s]\ndriver = files\nrig_camera = %s\npath = %s\ncount = 8\nrate = 30\n' \
			"$cam" "$cam" "$repo/tests/data/ego_demo/$cam"
	done >"$tmp/demo.conf"
	printf '[tracker]\nrig = %s\nmodel = %s\ninit_joints = %s\n[socket]\npath = %s\n' \
		"$data/rigs/ego_stereo.json" "$data/models/default.json" "$repo/tests/data/ego_demo/gt.json" \
		"$tmp/mocapd.sock" >>"$tmp/demo.conf"
	"$mocapd_bin" --config "$tmp/demo.conf" --check >"$tmp/check.log" 2>&1 ||
		{ cat "$tmp/check.log"; fail "$mocapd_bin --check"; }
	timeout 120 "$mocapd_bin" --config "$tmp/demo.conf" --print --exit-at-end >"$tmp/run.log" 2>&1
	rc=$?
	grep -q "$plugins/mocap-driver-files.so" "$tmp/run.log" ||
		{ tail -n 30 "$tmp/run.log"; fail "$mocapd_bin did not load $plugins"; }
	if grep -qi "opencl" "$tmp/run.log" && grep -q "error" "$tmp/run.log" && [ $rc -ne 0 ]; then
		echo "SKIP: the installed mocapd runs, but no usable OpenCL device here to track"
		exit 77
	fi
	[ $rc -eq 0 ] || { tail -n 30 "$tmp/run.log"; fail "$mocapd_bin exited $rc"; }
	n=$(grep -c "^frame .* ok " "$tmp/run.log")
	[ "$n" -ge 3 ] || { tail -n 30 "$tmp/run.log"; fail "$mocapd_bin tracked $n frame sets"; }
	echo "installed mocapd: $n frame sets tracked with $plugins"
}
