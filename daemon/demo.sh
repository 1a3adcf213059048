#!/bin/sh
# The demo behind `make demo`: mocapd tracks the bundled head-mounted clip
# (tests/data/ego_demo, two fisheye cameras, 60 frames) with the files
# driver and OpenCL (PoCL on the CPU), no hardware.  It ends with a short
# table: frame sets tracked, the mean joint error against the clip's ground
# truth next to the project's target, the tracking rate and the
# capture-to-publish latency; and overlays of a few frames, enlarged 3x,
# drawn with tools/mocap-render (the tracked skeleton: red = left side,
# blue = right, yellow = spine; the clip's ground truth in green), on a
# page with that legend: build/demo/overlays.html.
#
# -v (`make demo V=1`): every tracked skeleton live as well, through
# `mocapctl watch` (a client on the daemon's socket; its "frame N" counts
# the skeletons published, while pose_NNNNN.json and the overlays are
# numbered by the clip's frame).
#
# With config/models/ego_detector.onnx present the daemon also runs the 2D
# joint detector on both cameras ([detector] in config/demo.conf) and its
# keypoints feed the tracker; without it the demo tracks from colour alone.
#
# usage: daemon/demo.sh [-v] [BUILD_DIR]        (run from the repository root)
set -u
verbose=0
case ${1:-} in -v | --verbose) verbose=1; shift ;; esac
build=${1:-build}
out=$build/demo
mocapd=$build/bin/mocapd
mocapctl=$build/bin/mocapctl
render=$build/bin/mocap-render
clip=tests/data/ego_demo
sock=$out/mocapd.sock

for f in "$mocapd" "$render" "$build/drivers/mocap-driver-files.so"; do
	[ -e "$f" ] || { echo "demo: $f is not built (run make first)" >&2; exit 1; }
done
rm -rf "$out"
mkdir -p "$out"

model=config/models/ego_detector.onnx
if [ -e "$model" ]; then
	echo "== the 2D joint detector: $model (config/demo.conf [detector])"
else
	echo "== no $model (the shipped detector is not there yet): mocapd runs without the detector and says so"
fi
echo "== mocapd on $clip (config/demo.conf); log in $out/mocapd.log"
# --print goes to a file for the summary; on the terminal the skeletons
# come through mocapctl watch (a client), or the file is shown after.
"$mocapd" --config config/demo.conf --plugin-dir "$build/drivers" --socket "$sock" \
	--exit-at-end --save-poses "$out" --print >"$out/frames.txt" 2>"$out/mocapd.log" &
daemon=$!

if [ $verbose = 1 ] && [ -x "$mocapctl" ]; then
	# Connect as soon as the socket is there; the daemon builds its OpenCL
	# kernels first.
	i=0
	while [ ! -S "$sock" ] && kill -0 $daemon 2>/dev/null && [ $i -lt 600 ]; do
		sleep 0.1
		i=$((i + 1))
	done
	if [ -S "$sock" ]; then
		echo "== mocapctl watch (live skeletons, joint positions in metres, rig frame;"
		echo "   'frame N' counts published skeletons, the files are numbered by the clip's frame)"
		"$mocapctl" --socket "$sock" watch || true
	fi
fi
[ $verbose = 1 ] || echo "   (daemon/demo.sh -v, or make demo V=1, shows every skeleton live)"
wait $daemon
rc=$?
if [ $rc -ne 0 ]; then
	echo "demo: mocapd failed (exit $rc):" >&2
	tail -n 20 "$out/mocapd.log" >&2
	exit 1
fi
[ $verbose = 0 ] || [ -x "$mocapctl" ] || cat "$out/frames.txt"
[ $verbose = 0 ] || grep -E "tracker:|detector:|status:" "$out/mocapd.log" | tail -n 5

# The tracked frame closest to each of a few frame numbers.
nearest() {
	best=
	bestd=1000000
	for f in "$out"/pose_*.json; do
		[ -e "$f" ] || continue
		n=$(basename "$f" .json | sed 's/^pose_0*//')
		n=${n:-0}
		d=$((n > $1 ? n - $1 : $1 - n))
		if [ $d -lt $bestd ]; then best=$n; bestd=$d; fi
	done
	echo "$best"
}

# Overlays of three frames, both cameras, enlarged 3x.
made=0
for want in 5 30 55; do
	k=$(nearest $want)
	[ -n "$k" ] || continue
	kk=$(printf '%05d' "$k")
	for cam in left right; do
		"$render" --rig config/rigs/ego_stereo.json --model "$out/actor.json" \
			--pose "$out/pose_$kk.json" --cam $cam --overlay "$clip/$cam/$kk.jpg" --scale 3 \
			--gt "$clip/gt.json" --frame "$k" --out "$out/overlay_$kk" >/dev/null 2>>"$out/render.log" &&
			made=$((made + 1))
	done
done
[ $made -gt 0 ] || { echo "demo: no overlay was written (no pose tracked?)" >&2; exit 1; }

# The table, from mocapd's --print lines (frame N t=SECONDS STATE ...
# name=(x,y,z)), the clip's ground truth (docs/CONVENTIONS.md's evaluated
# joints, left camera frame), mocapd's status lines and its totals; and the
# overlay page.
/usr/bin/python3 daemon/demo_summary.py "$out" "$clip/gt.json" || { echo "demo: no summary (python3 failed)" >&2; exit 1; }
