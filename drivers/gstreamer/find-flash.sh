#!/bin/sh
# find-flash.sh VIDEO...: the time of the first flash (a frame whose mean
# brightness jumps by more than THRESHOLD, default 0.2 of full scale, over
# the frame before) in each video, and the `start` offsets of the gstreamer
# driver that line the videos up on it (the earliest flash gets 0).
# Uses gst-launch-1.0 and videoanalyse (gstreamer1.0-plugins-bad).
# docs/DRIVERS.md, "Several files as one rig".
set -eu
threshold=${THRESHOLD:-0.2}
[ $# -ge 1 ] || { echo "usage: $0 VIDEO..." >&2; exit 2; }
times=""
for f in "$@"; do
	[ -r "$f" ] || { echo "$f: not readable" >&2; exit 1; }
	t=$(gst-launch-1.0 -m filesrc location="$f" ! decodebin ! videoconvert ! videoanalyse ! \
		fakesink sync=false 2>/dev/null |
		awk -v th="$threshold" \
			-F'stream-time=\\(guint64\\)|, running-time|luma-average=\\(double\\)|, luma-variance' \
			'/GstVideoAnalyse/ { t = $2 / 1e9; y = $4
			   if (n++ && y - prev > th) { printf "%.3f\n", t; found = 1; exit }
			   prev = y }
			 END { if (!found) print "none" }')
	if [ "$t" = none ]; then
		echo "$f: no flash (no frame brighter than the one before by $threshold)" >&2
		exit 1
	fi
	echo "$f: flash at $t s"
	times="$times $t"
done
min=$(echo $times | tr ' ' '\n' | sort -g | head -n 1)
i=0
for f in "$@"; do
	i=$((i + 1))
	t=$(echo $times | cut -d' ' -f$i)
	echo "$f: start = $(echo "$t $min" | awk '{ printf "%.3f", $1 - $2 }')"
done
