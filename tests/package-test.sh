#!/bin/sh
# The Debian packages (debian/, docs/PACKAGING.md): dpkg-buildpackage -us -uc
# -b in a copy of the tree (the working tree's build/ is left alone, the
# packages land in a temporary folder), lintian (errors fail the test),
# apt-get install of the packages, then the installed programs: versions,
# the files where Debian wants them, the mocapd user, a libmocap example
# built with pkg-config, the Python module, and mocapd tracking the bundled
# demo clip with the installed rig, model and plugins (no plugin_dir).
# Last, apt-get purge.
#
# Needs root (CI runs as root) and dpkg-dev, debhelper and lintian (make
# deps); skips (77) otherwise, or when a mocapd package is already installed
# here (the test would replace and then purge it).
# Usage: tests/package-test.sh (from the repository root).
set -u
repo=$(pwd)
pkgs="mocapd libmocap1 libmocap-dev python3-mocap mocapd-doc"
skip() { echo "SKIP: $*"; exit 77; }
fail() { echo "FAIL: $*"; exit 1; }
. "$repo/tests/lib/installed-demo.sh"

[ "$(id -u)" -eq 0 ] || skip "not root: installing packages needs root"
for t in dpkg-buildpackage dh apt-get; do
	command -v $t >/dev/null || skip "no $t (make deps installs dpkg-dev and debhelper)"
done
for p in $pkgs; do
	if dpkg-query -W -f '${Status}' "$p" 2>/dev/null | grep -q 'ok installed'; then
		skip "$p is already installed here; not replacing it"
	fi
done

tmp=$(mktemp -d /tmp/mocap-package-XXXXXX)
installed=0
cleanup() {
	if [ $installed -eq 1 ]; then
		DEBIAN_FRONTEND=noninteractive apt-get purge -y $pkgs >"$tmp/purge.log" 2>&1 ||
			{ cat "$tmp/purge.log"; echo "FAIL: apt-get purge"; }
	fi
	rm -rf "$tmp"
}
trap cleanup EXIT
trap 'exit 1' INT TERM
ma=$(dpkg-architecture -qDEB_HOST_MULTIARCH)

# The tree as git sees it (tracked files and new ones not ignored), without
# build folders or anything ignored; without git, all but the build folders.
mkdir "$tmp/src"
if command -v git >/dev/null && git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
	git ls-files -z --cached --others --exclude-standard | xargs -0 -r sh -c \
		'for f; do [ -e "$f" ] || [ -L "$f" ] && printf "%s\0" "$f"; done; :' sh |
		tar --null -T - -cf - | tar -x -C "$tmp/src" || fail "copying the tree"
else
	tar --exclude=./.git --exclude=./build --exclude='./build-*' -cf - . | tar -x -C "$tmp/src" ||
		fail "copying the tree"
fi
[ -x "$tmp/src/debian/rules" ] || fail "no debian/rules in the copy"

start=$(date +%s)
(cd "$tmp/src" && dpkg-buildpackage -us -uc -b -jauto) >"$tmp/build.log" 2>&1 ||
	{ tail -n 40 "$tmp/build.log"; fail "dpkg-buildpackage"; }
echo "dpkg-buildpackage: $(( $(date +%s) - start )) s"
debs=""
for p in $pkgs; do
	d=$(ls "$tmp"/${p}_*.deb 2>/dev/null | head -n 1)
	[ -n "$d" ] || fail "no ${p}_*.deb built"
	debs="$debs $d"
	echo "built $(basename "$d") ($(stat -c %s "$d") bytes)"
done

if command -v lintian >/dev/null; then
	lintian --fail-on error --tag-display-limit 0 "$tmp"/mocapd_*.changes >"$tmp/lintian.log" 2>&1
	rc=$?
	grep -E '^[EWI]: ' "$tmp/lintian.log" | sed 's/^/lintian: /'
	[ $rc -eq 0 ] || fail "lintian reports errors (docs/PACKAGING.md lists the known findings)"
else
	echo "lintian not installed: not run"
fi

installed=1
DEBIAN_FRONTEND=noninteractive apt-get install -y $debs >"$tmp/install.log" 2>&1 ||
	{ tail -n 30 "$tmp/install.log"; fail "apt-get install of the packages"; }
for f in /usr/bin/mocapd /usr/bin/mocapctl /usr/bin/mocap-bench /usr/bin/mocap-detect /usr/bin/mocap-calibrate \
	/usr/lib/$ma/mocapd/drivers/mocap-driver-files.so /usr/lib/$ma/libmocap.so.1 /usr/lib/$ma/libmocap.so \
	/usr/include/mocap.h /usr/lib/$ma/pkgconfig/mocap.pc /usr/share/mocapd/models/default.json \
	/usr/share/mocapd/rigs/ego_stereo.json /lib/systemd/system/mocapd.service \
	/lib/systemd/system/mocapd.socket /usr/lib/sysusers.d/mocapd.conf /usr/lib/tmpfiles.d/mocapd.conf \
	/usr/lib/udev/rules.d/70-mocapd.rules /usr/share/man/man8/mocapd.8.gz /usr/share/man/man1/mocap-calibrate.1.gz /usr/share/doc/mocapd/SYSTEMD.md \
	/usr/share/doc/mocapd/PROTOCOL.md.gz; do
	[ -e "$f" ] || fail "$f is not installed"
done
# Every unit's Documentation= names what the packages install (VMC.md was
# shipped compressed as VMC.md.gz while mocap-vmc.service named VMC.md).
for u in /lib/systemd/system/mocapd.service /lib/systemd/system/mocap-vmc.service \
	/lib/systemd/system/mocap-detect.service; do
	[ -f "$u" ] || continue
	for d in $(sed -n 's/^Documentation=//p' "$u"); do
		case $d in
		file://*) [ -e "${d#file://}" ] || fail "$u: Documentation=$d is not installed" ;;
		man:*)
			page=${d#man:} name=${page%%(*} sec=${page#*(}
			sec=${sec%)}
			[ -e "/usr/share/man/man$sec/$name.$sec.gz" ] || fail "$u: Documentation=$d is not installed" ;;
		esac
	done
done
dpkg-query -W -f '${Conffiles}\n' mocapd | grep -q ' /etc/mocapd/mocapd.conf ' ||
	fail "/etc/mocapd/mocapd.conf is not a conffile of mocapd"
grep -q "/usr/share/mocapd" /etc/mocapd/mocapd.conf || fail "/etc/mocapd/mocapd.conf does not name /usr/share/mocapd"
if command -v systemd-sysusers >/dev/null; then
	getent passwd mocapd >/dev/null || fail "no user mocapd after the install (sysusers)"
	id -nG mocapd | grep -qw video || fail "mocapd is not in the video group"
fi

v=$(mocapctl --version 2>&1) || fail "mocapctl --version: $v"
echo "mocapctl --version: $v"
v=$(mocapd --version 2>&1) || fail "mocapd --version: $v"
echo "mocapd --version: $v"

cd "$tmp" || fail "cd $tmp"
# libmocap-dev: an example built against the installed library.
if command -v cc >/dev/null && command -v pkg-config >/dev/null; then
	cc -o "$tmp/event_loop" "$repo/examples/event_loop.c" $(pkg-config --cflags --libs mocap) \
		>"$tmp/cc.log" 2>&1 || { cat "$tmp/cc.log"; fail "building examples/event_loop.c with pkg-config mocap"; }
	ldd "$tmp/event_loop" | grep -q "libmocap.so.1 => .*/lib/$ma/libmocap.so.1" || fail "event_loop does not use the installed libmocap"
	echo "libmocap-dev: examples/event_loop.c builds with pkg-config mocap"
fi
# python3-mocap, from a folder with no mocap module of its own, with
# Debian's interpreter (the one the package is for; PATH may have another).
p=$(/usr/bin/python3 -c 'import mocap; print(mocap.__file__)' 2>&1) || fail "python3 -c 'import mocap': $p"
case $p in /usr/lib/python3/dist-packages/*) ;; *) fail "import mocap took $p" ;; esac
echo "python3-mocap: $p"

# The demo clip with the installed rig, model and plugins.
installed_demo mocapd /usr/share/mocapd "/usr/lib/$ma/mocapd/drivers"

cd "$repo" || fail "cd $repo"
installed=0
DEBIAN_FRONTEND=noninteractive apt-get purge -y $pkgs >"$tmp/purge.log" 2>&1 || { cat "$tmp/purge.log"; fail "apt-get purge"; }
for f in /usr/bin/mocapd /usr/lib/$ma/mocapd /usr/lib/$ma/libmocap.so.1 /etc/mocapd /usr/lib/python3/dist-packages/mocap.py \
	/usr/lib/python3/dist-packages/mocap; do
	[ ! -e "$f" ] || fail "apt-get purge left $f"
done
echo "PASS: packages built, installed, run and purged"
