#!/bin/sh
# Train the v3 head-mounted detector on a CUDA machine, from parts made by
# tools/train/pack.py (docs/DETECTOR.md, "v3 network").
#
#   tools/train/train_gpu.sh PARTS_DIR RESULT_DIR MINUTES
#
# Copies every PARTS_DIR/partNN into one data folder (build/gpu/data), trains
# for MINUTES of wall-clock time (the learning rate follows the time spent),
# and leaves in RESULT_DIR: best.pt (the epoch with the lowest validation
# loss), train.log, and ego_v3.onnx when this machine's torch can export it
# (else export on the CPU machine: train.py --arch v3 --export ... --weights best.pt).
# The checkpoint with the optimiser stays in build/gpu/ckpt.pt.
set -u
parts=$1 result=$2 minutes=$3
here=$(dirname "$0")
py=${PYTHON:-python3}
mkdir -p build/gpu/data "$result"
for p in "$parts"/part*; do
	[ -d "$p" ] && cp -r "$p"/. build/gpu/data/
done
echo "data: $(cat build/gpu/data/labels*.jsonl | wc -l) stereo pairs"
PYTHONUNBUFFERED=1 $py "$here/train.py" --data build/gpu/data --ckpt build/gpu/ckpt.pt --arch v3 \
	--pair-weight "${PAIR_WEIGHT:-10}" --seed "${SEED:-21}" --data-seed 21 --batch "${BATCH:-256}" \
	--lr "${LR:-3e-3}" --warmup 500 --epochs 100000 --steps-per-epoch "${STEPS:-1000}" \
	--minutes "$minutes" --amp --threads 8 --ckpt-minutes 1 2>&1 | tr '\r' '\n' \
	| awk '{ if (match($0, / step [0-9]+\//)) { n = substr($0, RSTART + 6, RLENGTH - 7) + 0; if (n % 200) next }
		print; fflush() }' | tee "$result/train.log"
cp build/gpu/best.pt "$result/best.pt"
$py "$here/train.py" --arch v3 --weights build/gpu/best.pt --export "$result/ego_v3.onnx" 2>&1 | tail -3 |
	tee -a "$result/train.log"
