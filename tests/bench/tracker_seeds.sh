#!/bin/sh
# Tracker accuracy over many seeds on every evaluation clip (ego and
# outside-in), for judging a tracker change: one seed moves a clip's MPJPE
# by up to 4 cm, so a change is compared on the mean of many seeds and its
# standard error (docs/BENCHMARKS_TRACKING.md, "Tracker budget against accuracy").
#
# usage: tracker_seeds.sh [-n SEEDS] [-s FIRST] [-j JOBS] [-b MOCAP_BENCH] [-d DIR] [-- MOCAP_BENCH_OPTIONS]
#   -n  seeds per clip (default 10)
#   -d  the clips are DIR's sub-folders with a gt.json (default: DATA_DIR's
#       ego/ and outside/ clips), e.g. the held-out clips of `make eval-clips`
#   -s  the first seed (default 1): seeds FIRST..FIRST+N-1
#   -j  runs at once (default 2; the fps column is only meaningful with -j 1)
# Prints one line per clip: mean MPJPE, its standard error, min and max over
# the seeds, and the mean fps and iterations per frame set.
set -eu

seeds=10
first=1
jobs=2
bench=build/bin/mocap-bench
data=${DATA_DIR:-../shared/data}
dir=
while getopts n:s:j:b:d: opt; do
	case $opt in
	n) seeds=$OPTARG ;;
	s) first=$OPTARG ;;
	j) jobs=$OPTARG ;;
	b) bench=$OPTARG ;;
	d) dir=$OPTARG ;;
	*) echo "usage: $0 [-n SEEDS] [-s FIRST] [-j JOBS] [-b MOCAP_BENCH] [-d DIR] [-- OPTIONS]" >&2; exit 2 ;;
	esac
done
shift $((OPTIND - 1))
[ "${1:-}" = "--" ] && shift

if [ ! -x "$bench" ]; then
	echo "tracker_seeds: $bench not built (make $bench)" >&2
	exit 1
fi
if [ -n "$dir" ]; then
	clips=$(for g in "$dir"/*/gt.json; do [ -f "$g" ] && dirname "$g"; done | sed 's|$|/|')
	where=$dir
else
	clips=$(ls -d "$data"/ego/*/ "$data"/outside/*/ 2>/dev/null || true)
	where="$data/ego or $data/outside"
fi
if [ -z "$clips" ]; then
	echo "tracker_seeds: no clips under $where, skipped"
	exit 0
fi

out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
for clip in $clips; do
	for s in $(seq "$first" $((first + seeds - 1))); do
		echo "$clip $s"
	done
done | BENCH="$bench" OUT="$out" OPTIONS="$*" xargs -P "$jobs" -L 1 sh -c '
	clip=$1 seed=$2
	name=$(basename "$(dirname "$clip")")_$(basename "$clip")
	# OPTIONS is split on purpose: mocap-bench options hold no spaces
	"$BENCH" --clip "$clip" --quiet --no-thesis --reference-frames 0 --seed "$seed" $OPTIONS \
		| grep "^RESULT" | sed "s/^/seed=$seed /" > "$OUT/$name.$seed" ||
		{ echo "tracker_seeds: $clip seed $seed failed" >&2; exit 255; }
' sh

for clip in $clips; do
	name=$(basename "$(dirname "$clip")")_$(basename "$clip")
	cat "$out/$name".* | awk -v clip="$name" '
		{ for (i = 1; i <= NF; i++) { split($i, kv, "="); v[kv[1]] = kv[2] }
		  n++; m = v["mpjpe_cm"]; s += m; ss += m * m; fps += v["fps"]; it += v["iterations"]
		  if (n == 1 || m < lo) lo = m; if (n == 1 || m > hi) hi = m }
		END { mean = s / n; var = n > 1 ? (ss - n * mean * mean) / (n - 1) : 0
		      if (var < 0) var = 0
		      printf "SEEDS clip=%s seeds=%d mpjpe_mean_cm=%.2f se_cm=%.2f min=%.2f max=%.2f fps_mean=%.1f iterations_mean=%.1f\n",
		             clip, n, mean, sqrt(var / n), lo, hi, fps / n, it / n }'
done
