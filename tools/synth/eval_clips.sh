#!/bin/sh
# The held-out evaluation clips (tools/synth/clip.py; docs/BENCHMARKS.md,
# "Held-out clips"): motions of the families no detector trained on and,
# for the "val" ones, the held-out build, garment and scene kind too; some
# with a bystander.  Renders those not yet complete into OUT/ego/NAME and
# OUT/outside/NAME (default OUT: build/clips), resuming a half-done clip;
# one Blender at a time, at nice 19.
#   tools/synth/eval_clips.sh [OUT] [BLENDER]
# --list prints the clips' folders and exits.
set -e
OUT=${1:-build/clips}
BLENDER=${2:-blender}
# kind/name          motion            first frames seed split bystander
CLIPS="
ego/sword_val        cmu_iclone/02_07  180 150 11 val   -
ego/scoop_val        cmu_iclone/02_06  0   150 12 val   cmu_iclone/02_10
ego/salsa_train      cmu_daz/60_10     95  150 13 train cmu_iclone/02_08
ego/salsa_val        cmu_daz/61_12     60  150 14 val   -
outside/sword_val    cmu_iclone/02_07  180 150 21 val   cmu_iclone/02_10
outside/salsa_train  cmu_daz/61_12     60  150 22 train -
"
if [ "$1" = "--list" ]; then
	echo "$CLIPS" | awk 'NF { print $1 }'
	exit 0
fi
echo "$CLIPS" | while read -r clip motion first frames seed split by; do
	[ -n "$clip" ] || continue
	[ -f "$OUT/$clip/gt.json" ] && continue # complete
	set -- --kind "${clip%%/*}" --out "$OUT/$clip" --motion "$motion" --first "$first" --frames "$frames" \
		--seed "$seed" --split "$split"
	[ "$by" = "-" ] || set -- "$@" --bystander "$by"
	nice -n 19 "$BLENDER" -b --factory-startup --python tools/synth/clip.py -- "$@" 2>&1 |
		grep --line-buffered -E "^clip|Error|error|Traceback|File " || true
	[ -f "$OUT/$clip/gt.json" ] || { echo "eval_clips: $clip is not complete" >&2; exit 1; }
done
