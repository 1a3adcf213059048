#!/bin/sh
# bench-latency: where a frame set's time goes in mocapd, capture to
# publish, at 30 and 60 fps, on an idle machine and with a CPU hog on one
# core.  mocapd plays the bundled clip (tests/data/ego_demo: two 256x256
# MJPEG cameras) in a loop through the files driver, tracks it with the
# default settings and the colours learnt on the first frame set (as
# mocap-bench does, so that the two track the same way), and after SECONDS
# the stage figures of the newest 1024 frame sets come from `mocapctl status --json` (STATUS's latency block).
#
#   tests/bench/latency.sh BUILD [SECONDS per run, default 60]
#
# LATENCY_RATES and LATENCY_LOADS choose the runs (default "30 60" and
# "idle hog detector"; detector: idle, with the shipped 2D joint detector
# in-process, config/models/ego_detector.onnx, on every frame of both
# cameras).  LATENCY_DETECTOR_NICE sets the detector's [detector] nice
# (default: the daemon's default).
#
# The files driver rather than the sim driver: sim renders each view on the
# CPU (about a second at 256x256), so it cannot deliver 30 or 60 fps on two
# cores without taking the tracker's time; the files driver decodes real
# MJPEG, as a USB camera's frames are.
set -eu
build=${1:?usage: latency.sh BUILD [SECONDS]}
secs=${2:-60}
repo=$(pwd)
[ -f tests/data/ego_demo/gt.json ] || { echo "bench-latency: run from the repository root"; exit 1; }
py=/usr/bin/python3
echo "bench-latency: $secs s per run; CPU: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(nproc) cores"
printf '%-4s %-8s %6s %8s  %-22s %-22s %-22s %-22s %-22s %-22s %s\n' fps load sets tracked/s \
	"ready p50/p99/max" "wait" "decode" "track" "publish" "total" "skipped behind/stale, incomplete"
for rate in ${LATENCY_RATES:-30 60}; do
	for load in ${LATENCY_LOADS:-idle hog detector}; do
		dir=$(mktemp -d /tmp/mocap-latency-XXXXXX)
		{
			printf '[daemon]\nplugin_dir = %s/%s/drivers\n' "$repo" "$build"
			for cam in left right; do
				printf '[camera %s]\ndriver = files\nrig_camera = %s\nloop = true\nrate = %s\npath = %s\n' \
					$cam $cam $rate "$repo/tests/data/ego_demo/$cam"
			done
		} > "$dir/mocapd.conf"
		cat >> "$dir/mocapd.conf" <<CONF
[tracker]
rig = $repo/config/rigs/ego_stereo.json
model = $repo/config/models/default.json
init_joints = $repo/tests/data/ego_demo/gt.json
calibrate_colors = true
[socket]
path = $dir/mocapd.sock
CONF
		if [ "$load" = detector ]; then
			printf '[detector]\nmodel = %s/config/models/ego_detector.onnx\n' "$repo" >> "$dir/mocapd.conf"
			if [ -n "${LATENCY_DETECTOR_NICE:-}" ]; then
				printf 'nice = %s\n' "$LATENCY_DETECTOR_NICE" >> "$dir/mocapd.conf"
			fi
		fi
		"$build/bin/mocapd" -c "$dir/mocapd.conf" > /dev/null 2> "$dir/mocapd.log" &
		daemon=$!
		hog=
		if [ "$load" = hog ]; then
			sh -c 'while :; do :; done' &
			hog=$!
		fi
		sleep "$secs"
		"$build/bin/mocapctl" --socket "$dir/mocapd.sock" status --json > "$dir/status.json" || true
		[ -n "$hog" ] && kill "$hog"
		kill "$daemon"
		wait "$daemon" || true
		$py - "$dir/status.json" "$rate" "$load" <<'PY' || { echo "bench-latency: no status ($dir)"; tail -n 5 "$dir/mocapd.log"; }
import json, sys
st = json.load(open(sys.argv[1]))
lat = st["latency"]
cell = lambda s: "%5.1f %5.1f %6.1f ms" % (lat[s]["p50_ms"], lat[s]["p99_ms"], lat[s]["max_ms"])
print("%-4s %-8s %6d %8.1f  %-22s %-22s %-22s %-22s %-22s %-22s %d/%d, %d" % (
    sys.argv[2], sys.argv[3], lat["window"], st["publish_fps"], cell("ready"), cell("wait"), cell("decode"),
    cell("track"), cell("publish"), cell("total"), lat["skipped_behind"], lat["skipped_stale"], lat["incomplete"]),
    end="")
det = st.get("detector", {})
if det.get("state") == "running":
    # used: views whose keypoints came in time for their frame set's tracking
    print("; detector %.1f views/s, %.2f ms per view, %.1f used/s" % (det["views_per_s"], det["ms_mean"],
                                                                     det["used_per_s"]), end="")
elif det.get("state") == "failed":
    print("; detector failed: %s" % det.get("message"), end="")
print()
PY
		rm -rf "$dir"
	done
done
