#!/bin/sh
# test_offline.sh: mocapd --offline tracks every frame set of recorded
# footage.  The demo clip (tests/data/ego_demo: two cameras, 60 frames at
# 30 fps) through config/demo.conf's tracker:
#   1. files driver, tracker off, `[daemon] offline = true` and
#      --exit-at-end: 60 complete frame sets at t = k/30 s (the offline
#      time origin keeps each frame's time in the recording);
#   2. files driver (rate = 30, as in the demo), tracking: exits 0 and all
#      60 frame sets are tracked, by --print and by the final "offline:"
#      log line, with none skipped;
#   3. the same frames as two MKVs, gstreamer driver with pace = asap:
#      likewise 60 of 60 (skipped, saying why, where GStreamer or an
#      element is missing).
# In 2 and 3 the drivers report how many frames each camera has (the
# driver ABI's frame_count), so the progress lines logged each second say
# "K / 60 frame sets, P %, ..., ETA S s" (tracking the clip takes 1.5-2 s
# here, so there is at least one; a run under 1.2 s need not have one).
# Live (without --offline) mocapd tracks only the newest due frame set, so
# with pace = asap it tracked 2 of the 60 before the offline mode existed.
# Wall times are printed, never asserted (the machine may be loaded).
# Run from the repository root; MOCAP_BUILD names the build folder.
set -u
build=${MOCAP_BUILD:-build}
root=$(pwd)
mocapd=$build/bin/mocapd
[ -x "$mocapd" ] || { echo "$mocapd is not built"; exit 1; }
tmp=$(mktemp -d /tmp/mocap-offline-XXXXXX)
trap 'rm -rf "$tmp"' EXIT
# Under ASan: the daemon's suppressions (OpenCL, ...) and GStreamer's (GLib).
cat tests/lsan.supp tests/drivers/gstreamer.supp >"$tmp/lsan.supp"
export LSAN_OPTIONS="suppressions=$tmp/lsan.supp:print_suppressions=0"
fail=0
check() { # check CONDITION-TEXT RESULT
	if [ "$2" = 1 ]; then echo "ok: $1"; else echo "FAIL: $1"; fail=1; fi
}

# config/demo.conf with absolute paths and its socket in $tmp.
make_conf() { # make_conf NAME
	sed -e "s|= \.\./|= $root/|; s|= rigs/|= $root/config/rigs/|; s|= models/|= $root/config/models/|" \
		-e "s|/tmp/mocapd-demo.sock|$tmp/$1.sock|" config/demo.conf >"$tmp/$1.conf"
}
tracker_off() { # tracker_off NAME: no [tracker] (nor [detector], which needs it)
	awk '/^\[(tracker|detector)\]/ { skip = 1; next } /^\[/ { skip = 0 } !skip' "$tmp/$1.conf" >"$tmp/$1.tmp"
	printf '\n[tracker]\nenabled = false\n' | cat "$tmp/$1.tmp" - >"$tmp/$1.conf"
}
to_mkv() { # to_mkv NAME: the cameras play $tmp/left.mkv and right.mkv as fast as taken
	sed -i -e "s|driver = files|driver = gstreamer|; /^rate = 30/d" \
		-e "s#^path = .*/ego_demo/\(left\|right\)\$#uri = $tmp/\1.mkv\npace = asap#" "$tmp/$1.conf"
}

run() { # run NAME [OPTION]: mocapd (--offline unless told) to the end; sets rc and secs
	start=$(date +%s.%N)
	timeout 300 "$mocapd" --config "$tmp/$1.conf" --plugin-dir "$build/drivers" "${2:---offline}" --print \
		>"$tmp/$1.txt" 2>"$tmp/$1.log"
	rc=$?
	secs=$(echo "$(date +%s.%N) $start" | awk '{ printf "%.1f", $1 - $2 }')
	[ "$rc" = 0 ] || tail -n 8 "$tmp/$1.log"
}

# Tracked frame sets by --print (their lines lack "(not tracked)"), the
# final progress line, and the mean joint error against gt.json in cm.
score() { # score NAME: "tracked error_cm"
	/usr/bin/python3 - "$tmp/$1.txt" tests/data/ego_demo/gt.json <<'PY'
import json, re, sys
gt = json.load(open(sys.argv[2]))
fps, frames = gt.get("fps", 30), gt["frames"]
joints = ["neck"] + [s + j for s in ("left_", "right_") for j in
                     ("shoulder", "elbow", "wrist", "hip", "knee", "ankle", "toe")]
tracked, errors, seen = 0, [], set()
for line in open(sys.argv[1]):
    m = re.match(r"frame \d+ t=([\d.]+) (\w+) .*cams 2/2", line)
    if not m or "(not tracked)" in line:
        continue
    k = round(float(m.group(1)) * fps)
    if k in seen:
        continue
    seen.add(k)
    tracked += 1
    truth = frames[k]["joints_left_cam"] if k < len(frames) else {}
    for name in joints:
        j = re.search(r" %s=\(([-\d.]+),([-\d.]+),([-\d.]+)\)" % name, line)
        if j and name in truth:
            errors.append(sum((float(a) - b) ** 2 for a, b in zip(j.groups(), truth[name])) ** 0.5)
print(tracked, "%.2f" % (100 * sum(errors) / len(errors)) if errors else "none")
PY
}

# 1. grouping only: every set, on the clip's time grid; the config key
# instead of --offline
make_conf group
tracker_off group
sed -i 's/^\[daemon\]/[daemon]\noffline = true/' "$tmp/group.conf"
run group --exit-at-end
sets=$(grep -c "cams 2/2 (not tracked)" "$tmp/group.txt")
grid=$(awk '/^frame/ { split($3, t, "="); k = NR - 1; if ((t[2] - k / 30) ^ 2 > 0.000001) bad++ }
	END { print bad ? 0 : 1 }' "$tmp/group.txt")
echo "files, tracker off: exit $rc, $sets complete frame sets in $secs s (the clip is 2.0 s)"
check "files, tracker off: exits 0" "$([ "$rc" = 0 ] && echo 1)"
check "files, tracker off: 60 complete frame sets, t = k/30 s" "$([ "$sets" = 60 ] && [ "$grid" = 1 ] && echo 1)"
check "files, tracker off: offline by the config key (its final line)" \
	"$(grep -q "offline: 60 frame sets, 0 tracked, .*skipped 0 behind" "$tmp/group.log" && echo 1)"

track() { # track NAME LABEL: runs the tracking config NAME and checks it
	run "$1"
	set -- "$1" "$2" $(score "$1")
	final=$(grep -c "offline: 60 frame sets, 60 tracked, .*skipped 0 behind" "$tmp/$1.log")
	lines=$(grep "offline: " "$tmp/$1.log" | grep -vc "offline: every frame set\|offline: 60 frame sets, 60 tracked, in")
	totals=$(grep -Ec "offline: [0-9]+ / 60 frame sets, [0-9]+ %, .*ETA [0-9]+ s" "$tmp/$1.log")
	long=$(echo "$secs" | awk '{ print ($1 >= 1.2) }')
	echo "$2: exit $rc, $3 of 60 frame sets tracked in $secs s (the clip is 2.0 s), mean joint error $4 cm"
	grep "offline:" "$tmp/$1.log" | sed 's/^/    /'
	check "$2: exits 0" "$([ "$rc" = 0 ] && echo 1)"
	check "$2: all 60 frame sets tracked" "$([ "$3" = 60 ] && echo 1)"
	check "$2: the final progress line says 60 of 60, none skipped" "$([ "$final" = 1 ] && echo 1)"
	check "$2: every progress line says K / 60 frame sets, P %, ETA ($totals of $lines)" \
		"$([ "$totals" = "$lines" ] && { [ "$lines" -gt 0 ] || [ "$long" = 0 ]; } && echo 1)"
}

# 2. the image folders
make_conf files
track files "files (rate = 30)"

# 3. the MKVs
gst=1
for e in imagesequencesrc jpegparse matroskamux matroskademux; do
	gst-inspect-1.0 --exists "$e" 2>/dev/null || { echo "gstreamer part skipped: element $e (or gst-inspect-1.0) not installed"; gst=0; break; }
done
[ -f "$build/drivers/mocap-driver-gstreamer.so" ] || { echo "gstreamer part skipped: the gstreamer driver is not built"; gst=0; }
if [ "$gst" = 1 ]; then
	for cam in left right; do
		gst-launch-1.0 -q imagesequencesrc location=tests/data/ego_demo/$cam/%05d.jpg start-index=0 \
			stop-index=59 framerate=30/1 ! jpegparse ! matroskamux ! filesink location="$tmp/$cam.mkv" || exit 1
	done
	make_conf mkv
	to_mkv mkv
	track mkv "gstreamer MKVs (pace = asap)"
fi
exit $fail
