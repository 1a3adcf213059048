#!/bin/sh
# The demo behind `make demo`: mocapd tracks the bundled head-mounted clip
# (tests/data/ego_demo, two fisheye cameras, 60 frames) with the files
# driver and OpenCL (PoCL on the CPU), no hardware.  The skeletons stream as
# text lines: from `mocapctl watch`, a client on the daemon's socket, when
# mocapctl is built, else from mocapd --print.  Afterwards a few frames are
# drawn with tools/mocap-render: the tracked skeleton (red = left side,
# blue = right, yellow = spine) and the clip's ground truth (green) over
# both camera images.
#
# With config/models/ego_detector.onnx present the daemon also runs the 2D
# joint detector on both cameras ([detector] in config/demo.conf) and its
# keypoints feed the tracker; without it the demo tracks from colour alone.
#
# usage: daemon/demo.sh BUILD_DIR        (run from the repository root)
set -u
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

if [ -x "$mocapctl" ]; then
	# Connect as soon as the socket is there; the daemon builds its OpenCL
	# kernels first.
	i=0
	while [ ! -S "$sock" ] && kill -0 $daemon 2>/dev/null && [ $i -lt 600 ]; do
		sleep 0.1
		i=$((i + 1))
	done
	if [ -S "$sock" ]; then
		echo "== mocapctl watch (live skeletons, joint positions in metres, rig frame)"
		"$mocapctl" --socket "$sock" watch || true
	fi
fi
wait $daemon
rc=$?
if [ $rc -ne 0 ]; then
	echo "demo: mocapd failed (exit $rc):" >&2
	tail -n 20 "$out/mocapd.log" >&2
	exit 1
fi
[ -x "$mocapctl" ] || cat "$out/frames.txt"
grep -E "tracker:|detector:|status:" "$out/mocapd.log" | tail -n 5

# The summary: frame sets tracked of the clip's, those skipped because the
# tracker was slower than the cameras, and the mean joint error against
# the clip's ground truth (docs/CONVENTIONS.md's evaluated joints, left
# camera frame).  A --print line is "frame N t=SECONDS STATE ... name=(x,y,z)".
echo "== summary"
/usr/bin/python3 - "$out/frames.txt" "$clip/gt.json" <<'PY' || echo "demo: no summary (python3 failed)"
import json, re, sys
gt = json.load(open(sys.argv[2]))
fps, frames = gt.get("fps", 30), gt["frames"]
evaluated = ["neck"] + [s + j for s in ("left_", "right_") for j in
                        ("shoulder", "elbow", "wrist", "hip", "knee", "ankle", "toe")]
tracked, errors = 0, []
for line in open(sys.argv[1]):
    m = re.match(r"frame \d+ t=([\d.]+) (\w+) ", line)
    if not m or "(not tracked)" in line:
        continue
    k = round(float(m.group(1)) * fps)
    tracked += 1
    if k >= len(frames):
        continue
    truth = frames[k]["joints_left_cam"]
    for name in evaluated:
        j = re.search(r" %s=\(([-\d.]+),([-\d.]+),([-\d.]+)\)" % name, line)
        if j and name in truth:
            errors.append(sum((float(a) - b) ** 2 for a, b in zip(j.groups(), truth[name])) ** 0.5)
n = len(frames)
print("frame sets tracked: %d of the clip's %d; skipped because the tracker was slower than the cameras: %d"
      % (tracked, n, max(n - tracked, 0)))
if errors:
    print("mean joint error against the clip's ground truth: %.1f cm (%d joint estimates)"
          % (100 * sum(errors) / len(errors), len(errors)))
PY
# mocapd's own count: why sets were skipped, and the latency.
grep -o "totals: .*" "$out/mocapd.log" | sed 's/^totals: /mocapd: /' || true

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

echo "== overlays (tracked skeleton in colour, ground truth in green)"
made=0
for want in 5 30 55; do
	k=$(nearest $want)
	[ -n "$k" ] || continue
	kk=$(printf '%05d' "$k")
	for cam in left right; do
		"$render" --rig config/rigs/ego_stereo.json --model "$out/actor.json" \
			--pose "$out/pose_$kk.json" --cam $cam --overlay "$clip/$cam/$kk.jpg" \
			--gt "$clip/gt.json" --frame "$k" --out "$out/overlay_$kk" >/dev/null 2>>"$out/render.log" &&
			made=$((made + 1))
	done
done
ls "$out"/overlay_*_overlay.png 2>/dev/null
[ $made -gt 0 ] || { echo "demo: no overlay was written (no pose tracked?)" >&2; exit 1; }
echo "== done: $made overlay images in $out"
