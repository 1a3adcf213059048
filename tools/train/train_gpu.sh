#!/bin/sh
# Train a head-mounted detector on a CUDA machine for a fixed wall-clock
# time (docs/DETECTOR_EXPERIMENTS.md, "v3 network").
#
#   tools/train/train_gpu.sh DATA RESULT MINUTES
#
# DATA is a data folder: tools/synth's, or the parts of `make
# detector-pack-v2` unpacked into one folder (for each part:
# tar -xzf PART.tar.gz -C DATA --strip-components=1); or several such
# folders joined by commas (v2's and v3's parts each in its own).  The learning rate
# follows the time spent (train.py --minutes).  RESULT gets best.pt (the
# epoch with the lowest validation loss) and train.log; the checkpoint with
# the optimiser goes to build/gpu/NAME/ckpt.pt (NAME: RESULT's last part).
# Environment: ARCH (v3), SEED (21), BATCH (256), LR (3e-3), STEPS (1000
# steps per epoch), PAIR_WEIGHT (10), FEET_WEIGHT (1), PYTHON (python3).  Several can run side
# by side on one GPU, each with its own RESULT.
# Export on the CPU machine afterwards:
#   train.py --arch v3 --weights RESULT/best.pt --export config/models/ego_detector.onnx
set -u
data=$1 result=$2 minutes=$3
here=$(dirname "$0")
name=$(basename "$result")
mkdir -p "$result" "build/gpu/$name"
PYTHONUNBUFFERED=1 ${PYTHON:-python3} "$here/train.py" --data "$data" --ckpt "build/gpu/$name/ckpt.pt" \
	--best "$result/best.pt" \
	--arch "${ARCH:-v3}" --pair-weight "${PAIR_WEIGHT:-10}" --feet-weight "${FEET_WEIGHT:-1}" --seed "${SEED:-21}" --data-seed 21 \
	--batch "${BATCH:-256}" --lr "${LR:-3e-3}" --warmup 500 --epochs 100000 --steps-per-epoch "${STEPS:-1000}" \
	--minutes "$minutes" --amp --threads 4 --ckpt-minutes 2 2>&1 | tr '\r' '\n' \
	| awk '{ if (match($0, / step [0-9]+\//)) { n = substr($0, RSTART + 6, RLENGTH - 7) + 0; if (n % 250) next }
		print; fflush() }' > "$result/train.log"
