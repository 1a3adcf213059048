#!/bin/bash
# vivid-test.sh: runs tests/drivers/test_v4l2_vivid against the kernel's vivid
# virtual video driver inside a qemu VM (see run-vm.sh).  vivid gets two
# webcam-like capture nodes and nothing else.  MOCAP_BUILD names the build
# folder with the test program and the plugin (default: build).
build=${MOCAP_BUILD:-build}
here=$(dirname "$0")
for f in "$build/tests/drivers/test_v4l2_vivid" "$build/drivers/mocap-driver-v4l2.so"; do
	[ -f "$f" ] || { echo "FAIL: $f not built"; exit 1; }
done
exec "$here/run-vm.sh" --name vivid \
	--module "vivid n_devs=2 node_types=0x1,0x1 num_inputs=1,1 input_types=0,0" \
	--file "$build/tests/drivers/test_v4l2_vivid" --file "$build/drivers/mocap-driver-v4l2.so" \
	-- ./test_v4l2_vivid
