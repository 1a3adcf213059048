#!/bin/sh
# Motion graphs (docs/MOTION_GRAPH.md, docs/BENCHMARKS.md "Motion graphs"):
#   1. Boukhayma & Boyer fig. 9 on the two CMU clips of shared/data/mocap:
#      mean and variance of the shortest-path cost over all frame pairs and
#      the density, Essential graph against motion graph, over alpha;
#   2. continuity of 10-minute walks on both graphs (mocap-graph check);
#   3. parametric blending of three walks to speeds between theirs;
#   4. build time and peak memory against the number of frames (clips of
#      shared/data/mocap and mocap-train added in turn).
# GRAPH_FPS (15), GRAPH_THREADS (0: every CPU), MOCAP_DATA_DIR (../shared/data).
# Usage: tests/bench/graph.sh BUILD_DIR   (from the repository root)
set -eu
build=${1:-build}
fps=${GRAPH_FPS:-15}
threads=${GRAPH_THREADS:-0}
data=${MOCAP_DATA_DIR:-../shared/data}
bin=$build/bin/mocap-graph
[ -r "$data/mocap/131_01.bvh" ] || { echo "bench-graph: no $data/mocap: skipped"; exit 0; }
tmp=$(mktemp -d /tmp/mocap-bench-graph-XXXXXX)
trap 'rm -rf "$tmp"' EXIT
echo "CPU: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(nproc) online"
echo
echo "== 1. Essential graph against motion graph (Boukhayma fig. 9), $fps fps =="
$bin compare --fps "$fps" --threads "$threads" --alpha 0.00003,0.0001,0.0003,0.001,0.003,0.01 \
	"$data/mocap/131_01.bvh" "$data/mocap/01_01.bvh"
echo
echo "== 2. 10-minute walks =="
$bin build --quiet --fps "$fps" --threads "$threads" --out "$tmp/g.mg" "$data/mocap/131_01.bvh" "$data/mocap/01_01.bvh"
for kind in essential motion; do
	$bin check "$tmp/g.mg" --seconds 600 --seed 1 --graph $kind || true
done
echo
echo "== 3. parametric blending (Casas): three walks of mocap-train =="
t=$data/mocap-train
if [ -d "$t" ]; then
	$bin build --quiet --fps "$fps" --threads "$threads" --out "$tmp/w.mg" walk="$t/cmu_mb/02_01.bvh" \
		walk="$t/cmu_daz/05_01.bvh" walk="$t/cmu_daz/07_03.bvh"
	for v in 1.1 1.3 1.4; do
		$bin blend "$tmp/w.mg" --class walk --speed $v --csv "$tmp/b.csv"
	done
fi
echo
echo "== 4. build time and memory against frames =="
t=$data/mocap-train
set -- "$data/mocap/131_01.bvh"
sets="1"
if [ -d "$t" ]; then
	run() { $bin build --quiet --fps "$fps" --threads "$threads" --out "$tmp/s.mg" "$@"; }
	run "$@"
	set -- "$@" "$data/mocap/01_01.bvh"; run "$@"
	set -- "$@" "$t/cmu_mb/02_01.bvh" "$t/cmu_mb/06_01.bvh" "$t/cmu_daz/05_01.bvh" "$t/cmu_daz/07_03.bvh"; run "$@"
	set -- "$@" "$t/cmu_daz/07_06.bvh" "$t/cmu_daz/08_08.bvh" "$t/cmu_daz/16_15.bvh" "$t/cmu_daz/16_31.bvh" \
		"$t/cmu_mb/06_02.bvh" "$t/cmu_mb/05_02.bvh"; run "$@"
	set -- "$@" "$t/cmu_mb/05_05.bvh" "$t/cmu_mb/05_06.bvh" "$t/cmu_mb/05_08.bvh" "$t/cmu_mb/05_13.bvh" \
		"$t/cmu_mb/05_17.bvh" "$t/cmu_mb/05_18.bvh"; run "$@"
else
	$bin build --quiet --fps "$fps" --threads "$threads" --out "$tmp/s.mg" "$@"
fi
