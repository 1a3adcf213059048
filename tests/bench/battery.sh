#!/bin/sh
# The head rig's battery for judging a tracker change (docs/BENCHMARKS.md,
# stops 56-58): the dev clips with the shipped detector's keypoints (from
# frame 0's ground truth and from the detections alone), with the realistic
# simulated detector and with 2 px keypoints, and the held-out clips of
# `make eval-clips` (and any other folder given with -d) with the detector's
# keypoints and with 2 px ones.  The detector's keypoints are written once
# per clip with --keypoints-out and replayed with --keypoints-in, so two
# binaries see the same keypoints and a run costs only the tracking.
#
# usage: battery.sh [-b MOCAP_BENCH] [-s "SEEDS"] [-d "HELD-OUT DIRS"] [-o OUT] [dev|held|px2|all]
#   -b  the mocap-bench to judge (default build/bin/mocap-bench)
#   -s  seeds (default "1 2 3")
#   -d  folders whose sub-folders with a gt.json are held-out clips
#       (default "build/clips/ego build/clips2/ego")
#   -o  results file (default build/battery/results.txt), one line a run:
#       GROUP CLIP SEED MPJPE_CM LONGEST_LOST_LIMB_S ACCEL_RATIO
#       LONGEST_LOST_IN_VIEW_S
#   dev: the dev clips only; held: the held-out ones only; px2: the 2 px
#   runs only; all (default): everything.
# Then `battery.sh -c OLD NEW` prints each group's and clip's means side by
# side and, over the runs both files have, how many moved by more than
# 0.05 cm either way.
set -eu

bench=build/bin/mocap-bench
seeds="1 2 3"
held_dirs="build/clips/ego build/clips2/ego"
out=build/battery/results.txt
data=${DATA_DIR:-../shared/data}
detector=config/models/ego_detector.onnx
kp_dir=build/battery/keypoints

compare() {
	awk -v old="$1" '
	FNR == 1 { file++ }
	NF >= 4 && $4 != "FAIL" { key = $1 " " $2 " " $3; v[file, key] = $4; keys[key] = 1
		clip[$1 " " $2] = 1 }
	END {
		for (c in clip) { split(c, p, " "); so = sn = n = 0
			for (k in keys) { split(k, q, " ")
				if (q[1] == p[1] && q[2] == p[2] && (1, k) in v && (2, k) in v) {
					so += v[1, k]; sn += v[2, k]; n++ } }
			if (n) printf "%-6s %-16s %10.2f %10.2f  (%d runs)\n", p[1], p[2], so / n, sn / n, n }
		for (k in keys) if ((1, k) in v && (2, k) in v) {
			d = v[2, k] - v[1, k]; if (d < -0.05) better++; if (d > 0.05) worse++ }
		printf "runs better by more than 0.05 cm: %d, worse: %d\n", better, worse
	}' "$1" "$2" | sort
}

if [ "${1:-}" = "-c" ]; then
	[ $# -eq 3 ] || { echo "usage: $0 -c OLD NEW" >&2; exit 2; }
	printf "%-6s %-16s %10s %10s\n" group clip old new
	compare "$2" "$3"
	exit 0
fi
while getopts b:s:d:o: opt; do
	case $opt in
	b) bench=$OPTARG ;;
	s) seeds=$OPTARG ;;
	d) held_dirs=$OPTARG ;;
	o) out=$OPTARG ;;
	*) echo "usage: $0 [-b MOCAP_BENCH] [-s SEEDS] [-d DIRS] [-o OUT] [dev|held|px2|all]" >&2; exit 2 ;;
	esac
done
shift $((OPTIND - 1))
what=${1:-all}
case $what in dev | held | px2 | all) ;; *) echo "battery: unknown set '$what'" >&2; exit 2 ;; esac
[ -x "$bench" ] || { echo "battery: $bench not built (make $bench)" >&2; exit 1; }
[ -f "$detector" ] || { echo "battery: no shipped detector ($detector)" >&2; exit 1; }
mkdir -p "$kp_dir" "$(dirname "$out")"
: >"$out"

# run GROUP CLIP_DIR OPTIONS...: one line of results, at the loop's $seed
# (sh has no locals: the function sets only names the loops do not use)
run() {
	run_group=$1 run_clip=$2
	shift 2
	r=$("$bench" --clip "$run_clip" --seed "$seed" --reference-frames 0 --no-thesis --quiet "$@" 2>&1 |
		grep -E '^(RESULT|LIMBS|JITTER)' || true)
	m=$(echo "$r" | sed -n 's/^RESULT.*mpjpe_cm=\([0-9.]*\).*/\1/p')
	w=$(echo "$r" | sed -n 's/^LIMBS.*worst_s=\([0-9.]*\).*/\1/p')
	a=$(echo "$r" | sed -n 's/^JITTER.*accel_ratio=\([0-9.]*\).*/\1/p')
	v=$(echo "$r" | sed -n 's/^LIMBS.*worst_in_view_s=\([0-9.]*\).*/\1/p')
	echo "$run_group $(basename "$run_clip") $seed ${m:-FAIL} ${w:--} ${a:--} ${v:--}" >>"$out"
}

# keypoints CLIP_DIR: the shipped detector's keypoints of the clip, once
keypoints() {
	kp="$kp_dir/$(basename "$1").kpj"
	[ -s "$kp" ] || "$bench" --clip "$1" --seed 1 --reference-frames 0 --no-thesis --quiet \
		--detector "$detector" --keypoints-out "$kp" >/dev/null 2>&1 ||
		echo "battery: no keypoints for $1" >&2
	echo "$kp"
}

for seed in $seeds; do
	if [ "$what" != held ]; then
		for c in walk_131_01 jumps_01_01; do
			d=$data/ego/$c
			[ -f "$d/gt.json" ] || { echo "battery: $d not found" >&2; exit 1; }
			if [ "$what" != px2 ]; then
				kp=$(keypoints "$d")
				run det "$d" --keypoints-in "$kp"
				run idet "$d" --keypoints-in "$kp" --init detect
				run ego "$d" --simulated-detector 4 --sim-preset ego
			fi
			run 2px "$d" --simulated-detector 2
		done
	fi
	[ "$what" = dev ] && continue
	for dir in $held_dirs; do
		for d in "$dir"/*/; do
			d=${d%/}
			[ -f "$d/gt.json" ] || continue
			[ "$what" = px2 ] || run hdet "$d" --keypoints-in "$(keypoints "$d")"
			run h2px "$d" --simulated-detector 2
		done
	done
done
echo "battery: $(grep -c . "$out") runs in $out"
