#!/bin/bash
# run-vm.sh: runs a test program inside a small qemu VM (software emulation,
# TCG) that boots the host's Debian kernel with a busybox initramfs, loads the
# given kernel modules, and runs one command.  The guest prints the command's
# output and its exit status on the serial console; this script prints the
# output and exits with that status (0 pass, 77 skip, else fail).
#
# Usage: run-vm.sh --name NAME [--module "MOD [PARAM=V ...]"]... \
#                  [--file PATH]... -- COMMAND [ARG...]
#   --module  a module to load with modprobe's dependency order (repeatable)
#   --file    a file copied to /test/ in the guest, with the shared libraries
#             it needs (from ldd) at their own paths (repeatable)
#   --env     VAR=VALUE set for the command (repeatable)
#   --udev    run systemd-udevd in the guest (from the host's udevadm), so
#             that libudev users (libcamera, libusb hotplug) see initialised
#             devices and hotplug events
#   COMMAND   run in the guest with MOCAP_DRIVER_DIR=/test
# Environment: MOCAP_BUILD (work folder parent, default build),
#              MOCAP_VM_TIMEOUT (seconds, default 300), MOCAP_VM_KEEP=1 keeps
#              the work folder.
# Exits 77 with "SKIP: reason" when no VM can run here (no qemu, no kernel
# image with the modules, no static busybox, no cpio).
set -u

skip() { echo "SKIP: $*"; exit 77; }
fail() { echo "FAIL: $*"; exit 1; }

name=vm
modules=()
files=()
envs=()
udev=0
while [ $# -gt 0 ]; do
	case $1 in
	--name) name=$2; shift 2 ;;
	--module) modules+=("$2"); shift 2 ;;
	--file) files+=("$2"); shift 2 ;;
	--env) envs+=("$2"); shift 2 ;;
	--udev) udev=1; shift ;;
	--) shift; break ;;
	*) fail "run-vm.sh: unknown option $1" ;;
	esac
done
[ $# -gt 0 ] || fail "run-vm.sh: no command"
command=("$@")

qemu=$(command -v qemu-system-x86_64) || skip "qemu-system-x86_64 not found (Debian package qemu-system-x86)"
command -v cpio >/dev/null || skip "cpio not found"
busybox=""
for b in /bin/busybox /usr/bin/busybox; do
	if [ -x "$b" ] && ! ldd "$b" >/dev/null 2>&1; then busybox=$b; break; fi
done
[ -n "$busybox" ] || skip "no statically linked busybox (Debian package busybox-static)"

# The newest kernel image whose modules include every module asked for.
kernel="" kver=""
for k in $(ls /boot/vmlinuz-* 2>/dev/null | sort -rV); do
	v=${k#/boot/vmlinuz-}
	ok=1
	for m in "${modules[@]}"; do
		modprobe -S "$v" --show-depends ${m%% *} >/dev/null 2>&1 || { ok=0; break; }
	done
	if [ $ok = 1 ]; then kernel=$k; kver=$v; break; fi
done
[ -n "$kernel" ] || skip "no /boot/vmlinuz-* with modules ${modules[*]%% *} in /lib/modules (Debian package linux-image-amd64)"
[ -r "$kernel" ] || skip "$kernel is not readable by $(id -un)"

work=${MOCAP_BUILD:-build}/vm/$name
rm -rf "$work"
root=$work/initramfs
mkdir -p "$root"/{bin,dev,proc,sys,tmp,test,modules} || fail "cannot create $root"
cp "$busybox" "$root/bin/busybox"

# Modules, in dependency order, decompressed (busybox insmod takes plain .ko).
: >"$root/modules/order"
n=0
for m in "${modules[@]}"; do
	mod=${m%% *}
	params=""
	[ "$mod" != "$m" ] && params=${m#* }
	while read -r verb path rest; do
		[ "$verb" = insmod ] || continue
		base=$(basename "$path")
		plain=${base%.xz}; plain=${plain%.zst}; plain=${plain%.gz}
		grep -q " $plain\$\| $plain " "$root/modules/order" 2>/dev/null && continue
		case $base in
		*.xz) xz -dc "$path" >"$root/modules/$plain" ;;
		*.zst) zstd -qdc "$path" >"$root/modules/$plain" ;;
		*.gz) gzip -dc "$path" >"$root/modules/$plain" ;;
		*) cp "$path" "$root/modules/$plain" ;;
		esac || fail "cannot copy module $path"
		p=""
		[ "${plain%.ko}" = "$mod" ] && p=$params
		n=$((n + 1))
		echo "$n $plain $p" >>"$root/modules/order"
	done < <(modprobe -S "$kver" --show-depends "$mod")
done

# Files and the shared libraries they load (and the dynamic loader).
copy_with_libs() {
	local f=$1
	cp "$f" "$root/test/" || fail "cannot copy $f"
	ldd "$f" 2>/dev/null | awk '/=> \//{print $3} /^\t\//{print $1}' | while read -r lib; do
		[ -e "$root$lib" ] && continue
		mkdir -p "$root$(dirname "$lib")"
		cp -L "$lib" "$root$lib"
	done
}
for f in "${files[@]}"; do copy_with_libs "$f"; done

udev_start=""
if [ $udev = 1 ]; then
	udevadm=$(command -v udevadm) || skip "udevadm not found (Debian package udev)"
	copy_with_libs "$udevadm"
	mkdir -p "$root/usr/bin" "$root/lib/systemd" "$root/run" "$root/etc/udev"
	mv "$root/test/udevadm" "$root/usr/bin/udevadm"
	ln -s /usr/bin/udevadm "$root/lib/systemd/systemd-udevd"
	udev_start='mount -t tmpfs tmpfs /run
mkdir -p /run/udev
/lib/systemd/systemd-udevd --daemon 2>/dev/null
/usr/bin/udevadm trigger --action=add
/usr/bin/udevadm settle --timeout=20'
fi

cat >"$root/init" <<EOF
#!/bin/busybox sh
/bin/busybox --install -s /bin
export PATH=/bin
mount -t proc proc /proc
mount -t sysfs sysfs /sys
mount -t devtmpfs devtmpfs /dev
mount -t tmpfs tmpfs /tmp
while read -r n ko params; do
	insmod /modules/\$ko \$params || echo "MOCAP-VM: insmod \$ko failed"
done </modules/order
$udev_start
echo MOCAP-VM-BEGIN
cd /test
MOCAP_DRIVER_DIR=/test ASAN_OPTIONS=detect_leaks=1 ${envs[*]} ${command[*]} 2>&1
echo "MOCAP-VM-RESULT \$?"
poweroff -f
EOF
chmod 755 "$root/init"
(cd "$root" && find . | cpio -o -H newc --quiet | gzip -1) >"$work/initramfs.cpio.gz" ||
	fail "cannot build the initramfs"

log=$work/console.log
start=$(date +%s)
timeout "${MOCAP_VM_TIMEOUT:-300}" "$qemu" -accel tcg -cpu max -m 1024 -smp 1 -nodefaults -no-user-config \
	-display none -no-reboot -serial "file:$log" \
	-kernel "$kernel" -initrd "$work/initramfs.cpio.gz" \
	-append "console=ttyS0 panic=-1 quiet loglevel=3 rdinit=/init" >"$work/qemu.out" 2>&1
qrc=$?
secs=$(( $(date +%s) - start ))
[ $qrc = 124 ] && { tail -n 40 "$log"; fail "the VM ran past ${MOCAP_VM_TIMEOUT:-300} s"; }
[ -s "$log" ] || { cat "$work/qemu.out"; fail "the VM printed nothing (qemu exit $qrc)"; }
sed -n '/MOCAP-VM-BEGIN/,/MOCAP-VM-RESULT/p' "$log" | sed '1d;$d' | tr -d '\r'
grep "MOCAP-VM: " "$log"
rc=$(sed -n 's/.*MOCAP-VM-RESULT \([0-9]*\).*/\1/p' "$log" | tail -n 1)
if [ -z "$rc" ]; then
	tail -n 40 "$log"
	fail "the VM did not report a result (qemu exit $qrc)"
fi
echo "VM $name: kernel $kver, guest exit $rc, ${secs} s"
[ "${MOCAP_VM_KEEP:-0}" = 1 ] || rm -rf "$root"
exit "$rc"
