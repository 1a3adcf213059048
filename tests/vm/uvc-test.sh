#!/bin/bash
# uvc-test.sh: runs tests/drivers/test_uvc_vm inside a qemu VM (see
# run-vm.sh) where the kernel's uvcvideo driver sees a USB camera made of
# software: tests/vm/uvc_gadget on the device side of dummy_hcd, through
# gadgetfs.  Exercises the v4l2 and usb plugins against a real USB video
# stack, with systemd-udevd running so that libusb hotplug events flow.
# MOCAP_BUILD names the build folder (default: build); MOCAP_VM_ENV one
# VAR=VALUE for the guest's test (e.g. LIBUSB_DEBUG=4).
build=${MOCAP_BUILD:-build}
here=$(dirname "$0")
files=()
for f in tests/drivers/test_uvc_vm tests/vm/uvc_gadget drivers/mocap-driver-v4l2.so \
	drivers/mocap-driver-usb.so; do
	[ -f "$build/$f" ] || { echo "FAIL: $build/$f not built"; exit 1; }
	files+=(--file "$build/$f")
done
run() {
	"$here/run-vm.sh" --name uvc --udev --module dummy_hcd --module gadgetfs --module uvcvideo \
		"${files[@]}" ${MOCAP_VM_ENV:+--env "$MOCAP_VM_ENV"} -- ./test_uvc_vm
}
# The guest's software USB camera (dummy_hcd + gadgetfs) is itself flaky
# under load: once in about six runs here the guest kernel oopsed in the
# gadget, or the camera never came back after a replug.  A failed run is
# printed whole and run once more; the test passes only if that second run
# passes on its own.
run && exit 0
echo "uvc-test.sh: the first VM run failed (above); running it once more"
run
