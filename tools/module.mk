# tools/: the 2D joint detector's data generator (tools/synth/, Blender) and
# trainer (tools/train/, PyTorch).  Not part of `make all`: these need
# `make deps-train` and take an hour or more.  See docs/DETECTOR.md.
#
#   make detector-data      render DETECTOR_FRAMES stereo pairs (resumes)
#   make detector-data-v2   the v2 data (held-out factors, bystanders): a resumable
#                           job into $(DETECTOR_DIR)/v2 (progress: detector-progress-v2)
#   make detector-data-v3   the v3 data (v2 + feet and shoulders of more shapes and
#                           colours): into $(DETECTOR_DIR)/v3
#   make detector-finetune-v3  the shipped live model trained further on the v3 data
#   make detector-train-v2  stage 1 on the v2 data (resumes from $(DETECTOR_DIR)/v2/ckpt.pt)
#   make detector-train-mn  the head rig's network started from MoveNet (--arch mn), 75 min
#   make detector-offline   config/models/ego_offline_detector.onnx: mn and the live model averaged
#   make detector-pack-v2   the v2 data as WebP parts in $(DETECTOR_DIR)/v2/pack, each one
#                           tar.gz, for training on a GPU machine (tools/train/train_gpu.sh);
#                           detector-pack-v3 the same for v3
#   make detector-train     train, stage 1 (resumes from $(DETECTOR_DIR)/ckpt.pt)
#   make detector-finetune  stage 2 (resumes from $(DETECTOR_DIR)/stage2/ckpt.pt)
#   make detector-export    export stage 2's best checkpoint to config/models/ego_detector.onnx
#   make detector-report    2D error report on ../shared/data/ego/*
#   make eval-clips         the held-out evaluation clips, head-mounted and outside-in
#                           (tools/synth/clip.py, the list in tools/synth/eval_clips.sh) into
#                           $(EVAL_CLIPS_DIR), 6-15 minutes a clip on one core; resumes;
#                           `make bench-heldout` tracks them
#   make detector-data-outside, detector-train-outside, detector-finetune-outside,
#   detector-export-outside, detector-report-outside: the same for the outside-in model
#   ($(DETECTOR_OUTSIDE_DIR)/outside_detector.onnx: the shipped outside-in model is now
#   MoveNet, see tools/convert/module.mk; ../shared/data/outside/*)
#
# Long jobs: run them under nohup (they resume where they stopped).

DETECTOR_DIR ?= $(BUILD)/detector
DETECTOR_SEED ?= 1
DETECTOR_FRAMES ?= 12000
DETECTOR_SHARDS ?= 2
DETECTOR_EPOCHS ?= 80
BLENDER ?= blender
TRAIN_PYTHON ?= /usr/bin/python3
MOCAP_TRAIN_DIR ?= $(or $(MOCAP_DATA_DIR),../shared/data)/mocap-train
MOCAP_EGO_DIR ?= $(or $(MOCAP_DATA_DIR),../shared/data)/ego

.PHONY: detector-data detector-train detector-finetune detector-export detector-report

# The trainer's left/right figures and penalty (tools/train/test_metrics.py).
# It needs `make deps-train` (python3-torch, python3-numpy); without them it
# says so and skips, as on CI.
CHECKS += check-train-tools
.PHONY: check-train-tools
check-train-tools:
	@if $(TRAIN_PYTHON) -c 'import torch, numpy, pytest' 2>/dev/null; then \
		PYTHONDONTWRITEBYTECODE=1 $(TRAIN_PYTHON) -m pytest -q -p no:cacheprovider tools/train/test_metrics.py tools/train/test_pack.py \
		  tools/train/test_pretrained.py tools/train/test_stereo.py tools/train/test_onnx_import.py tools/train/test_augment_look.py tools/synth/test_job.py \
		  tools/synth/test_clip.py; \
	else echo "SKIP check-train-tools: no python3-torch, python3-numpy or pytest for $(TRAIN_PYTHON) (make deps-train)"; fi
.PHONY: detector-data-outside detector-train-outside detector-finetune-outside detector-export-outside \
	detector-report-outside

# DETECTOR_SHARDS parallel chains of Blender processes, one thread each,
# frames split evenly.  Each process renders at most DETECTOR_CHUNK frames:
# Blender 3.4 grows by about 2 MB per stereo pair (two 6000-frame processes
# reached 11 GB each), so a long run in one process ends in the OOM killer.
# Which process renders a frame does not change it (see docs/DETECTOR.md).
DETECTOR_CHUNK ?= 1000
detector-data:
	mkdir -p $(DETECTOR_DIR)/data $(DETECTOR_DIR)/logs
	n=$$(( $(DETECTOR_FRAMES) / $(DETECTOR_SHARDS) )); \
	for s in $$(seq 0 $$(( $(DETECTOR_SHARDS) - 1 ))); do \
	  ( f=$$(( s * n )); e=$$(( f + n )); while [ $$f -lt $$e ]; do \
	      c=$$(( e - f < $(DETECTOR_CHUNK) ? e - f : $(DETECTOR_CHUNK) )); \
	      nice -n 10 $(BLENDER) -b --factory-startup --python tools/synth/render.py -- \
	        --out $(DETECTOR_DIR)/data --mocap $(MOCAP_TRAIN_DIR) --seed $(DETECTOR_SEED) \
	        --first $$f --count $$c 2>&1 | grep -a --line-buffered 'synth:' > $(DETECTOR_DIR)/logs/render_$$f.log || exit 1; \
	      f=$$(( f + c )); done ) & \
	done; wait; grep -h 'synth:' $(DETECTOR_DIR)/logs/render_*.log | tail -n 4

# The v2 data (docs/DETECTOR.md, "v2 data", issue 36): 4x the v1 training
# views, validation held out by motion family, build, garment and scene kind
# together.  tools/synth/job.py keeps DETECTOR_SHARDS Blender processes busy
# on DETECTOR_V2_CHUNK-pair chunks; every pair is a checkpoint, so running
# the same command again resumes.  Progress and ETA: $(DETECTOR_V2_DIR)/progress.txt
# (make detector-progress-v2).  Start it with
#   nohup nice -n 19 make detector-data-v2 > build/detector/v2.log 2>&1 &
DETECTOR_V2_DIR ?= $(DETECTOR_DIR)/v2
DETECTOR_V2_SEED ?= 21
DETECTOR_V2_TRAIN ?= 55200
DETECTOR_V2_VAL ?= 6000
DETECTOR_V2_CHUNK ?= 400
DETECTOR_V2_NICE ?= 19
DETECTOR_V2_EPOCHS ?= 36
.PHONY: detector-data-v2 detector-progress-v2 detector-train-v2
# One render job (tools/synth/job.py): folder, seed, training and
# validation pairs, data version; the data targets add how to render, the
# progress targets --status.
render_job = $(TRAIN_PYTHON) tools/synth/job.py --out $(1) --seed $(2) --train $(3) --val $(4) --data-version $(5)
render_how = --blender $(BLENDER) --mocap $(MOCAP_TRAIN_DIR) --shards $(DETECTOR_SHARDS) \
	--chunk $(DETECTOR_V2_CHUNK) --nice $(DETECTOR_V2_NICE)
detector-data-v2:
	$(call render_job,$(DETECTOR_V2_DIR),$(DETECTOR_V2_SEED),$(DETECTOR_V2_TRAIN),$(DETECTOR_V2_VAL),2) $(render_how)

detector-progress-v2:
	@$(call render_job,$(DETECTOR_V2_DIR),$(DETECTOR_V2_SEED),$(DETECTOR_V2_TRAIN),$(DETECTOR_V2_VAL),2) --status

# The v3 data: v2's held-out factors and sizes, plus feet and shoulders of
# more shapes and colours (render.py --data-version 3;
# docs/DETECTOR_EXPERIMENTS.md, "v3 data").  Another seed, so that its
# poses are not v2's.  Resumable like v2:
#   nohup nice -n 19 make detector-data-v3 > build/detector/v3.log 2>&1 &
DETECTOR_V3_DIR ?= $(DETECTOR_DIR)/v3
DETECTOR_V3_SEED ?= 31
# half of v2's size: trained together with v2, it adds variety, not volume
DETECTOR_V3_TRAIN ?= 27600
DETECTOR_V3_VAL ?= 3000
.PHONY: detector-data-v3 detector-progress-v3
detector-data-v3:
	$(call render_job,$(DETECTOR_V3_DIR),$(DETECTOR_V3_SEED),$(DETECTOR_V3_TRAIN),$(DETECTOR_V3_VAL),3) $(render_how)

detector-progress-v3:
	@$(call render_job,$(DETECTOR_V3_DIR),$(DETECTOR_V3_SEED),$(DETECTOR_V3_TRAIN),$(DETECTOR_V3_VAL),3) --status

# The shipped live model trained further on the v3 data for
# DETECTOR_FT_MINUTES (train.py --init MODEL.onnx: its checkpoint is gone,
# so its weights come from the ONNX file and its BatchNorms stay frozen;
# docs/DETECTOR_EXPERIMENTS.md, "Fine-tuning the shipped model").  It can
# start while the render job runs: the labels are read again each epoch.
DETECTOR_FT_DIR ?= $(DETECTOR_DIR)/ft
DETECTOR_FT_MINUTES ?= 30
DETECTOR_FT_LR ?= 3e-4
# 2 when nothing else runs; 1 beside a render job (two torch threads then
# crawl)
DETECTOR_FT_THREADS ?= 2
# more train.py options, e.g. --aug-look (stop 48: make detector-finetune-v3
# DETECTOR_FT_ARGS=--aug-look DETECTOR_FT_DIR=build/detector/look
# DETECTOR_FT_MINUTES=105; docs/DETECTOR_EXPERIMENTS.md)
DETECTOR_FT_ARGS ?=
.PHONY: detector-finetune-v3
detector-finetune-v3:
	mkdir -p $(DETECTOR_FT_DIR)
	nice -n 10 $(TRAIN_PYTHON) tools/train/train.py --data $(DETECTOR_V3_DIR)/data --ckpt $(DETECTOR_FT_DIR)/ckpt.pt \
	  --init config/models/ego_detector.onnx --arch v2 --seed 44 --data-seed $(DETECTOR_V3_SEED) \
	  --pair-weight $(DETECTOR_V2_PAIR) --epochs 200 --steps-per-epoch 500 --lr $(DETECTOR_FT_LR) --threads $(DETECTOR_FT_THREADS) \
	  --minutes $(DETECTOR_FT_MINUTES) --resume $(DETECTOR_FT_ARGS)

# For a GPU machine (docs/DETECTOR_EXPERIMENTS.md, "v3 network and GPU training"): parts
# of at most DETECTOR_PACK_MB MB of WebP views, each packed as PART.tar.gz;
# there, unpack them all into one folder and run tools/train/train_gpu.sh.
DETECTOR_PACK_MB ?= 42.5
# detector-pack-v3 does the same for the v3 data: unpack v2's and v3's
# parts into two folders there and give train_gpu.sh both, joined by a
# comma (each numbers its own frames).
define detector_pack
	rm -rf $(1)/pack
	$(TRAIN_PYTHON) tools/train/pack.py --data $(1)/data --out $(1)/pack --part-mb $(DETECTOR_PACK_MB)
	cd $(1)/pack && for p in part*; do tar -czf $$p.tar.gz $$p && rm -r $$p; done
endef
.PHONY: detector-pack-v2 detector-pack-v3
detector-pack-v2:
	$(call detector_pack,$(DETECTOR_V2_DIR))
detector-pack-v3:
	$(call detector_pack,$(DETECTOR_V3_DIR))

# The v2 network (common.build_model("v2")) with the left/right overlap
# penalty.  One torch thread: two ran 10x slower here whenever anything else
# (a renderer, a build) shared the two cores.
DETECTOR_V2_ARCH ?= v2
DETECTOR_V2_PAIR ?= 10
DETECTOR_V2_STEPS ?= 500
DETECTOR_V2_THREADS ?= 1
detector-train-v2:
	nice -n 10 $(TRAIN_PYTHON) tools/train/train.py --data $(DETECTOR_V2_DIR)/data \
	  --ckpt $(DETECTOR_V2_DIR)/ckpt.pt --seed $(DETECTOR_V2_SEED) --data-seed $(DETECTOR_V2_SEED) \
	  --arch $(DETECTOR_V2_ARCH) --pair-weight $(DETECTOR_V2_PAIR) --epochs $(DETECTOR_V2_EPOCHS) \
	  --steps-per-epoch $(DETECTOR_V2_STEPS) --threads $(DETECTOR_V2_THREADS) --resume

# The head rig's network started from MoveNet (--arch mn, docs/DETECTOR.md
# "Offline model"): 75 minutes of training on the v2 data, two threads (this
# network is 8x slower to train than v2), resumable; then the offline model,
# its heat maps averaged with the shipped live model's, and its report.
DETECTOR_MN_DIR ?= $(DETECTOR_DIR)/mn
DETECTOR_MN_MINUTES ?= 75
DETECTOR_OFFLINE ?= config/models/ego_offline_detector.onnx
.PHONY: detector-train-mn detector-offline
detector-train-mn:
	mkdir -p $(DETECTOR_MN_DIR)
	nice -n 5 $(TRAIN_PYTHON) tools/train/train.py --data $(DETECTOR_V2_DIR)/data \
	  --ckpt $(DETECTOR_MN_DIR)/ckpt.pt --seed $(DETECTOR_V2_SEED) --data-seed $(DETECTOR_V2_SEED) \
	  --arch mn --pair-weight $(DETECTOR_V2_PAIR) --epochs 40 --steps-per-epoch $(DETECTOR_V2_STEPS) \
	  --threads 2 --lr 1e-3 --minutes $(DETECTOR_MN_MINUTES) --resume

detector-offline:
	$(TRAIN_PYTHON) tools/train/train.py --weights $(DETECTOR_MN_DIR)/best.pt --seed $(DETECTOR_V2_SEED) \
	  --data-seed $(DETECTOR_V2_SEED) --export $(DETECTOR_MN_DIR)/ego_mn.onnx
	$(TRAIN_PYTHON) tools/train/ensemble.py config/models/ego_detector.onnx $(DETECTOR_MN_DIR)/ego_mn.onnx \
	  $(DETECTOR_OFFLINE)
	$(TRAIN_PYTHON) tools/train/train.py --weights $(DETECTOR_OFFLINE) --ego $(MOCAP_EGO_DIR) \
	  --data $(DETECTOR_V2_DIR)/data --report --report-out $(DETECTOR_MN_DIR)/offline_report.json
	$(TRAIN_PYTHON) tools/train/ensemble.py config/models/ego_detector.onnx $(DETECTOR_MN_DIR)/ego_mn.onnx \
	  $(DETECTOR_OFFLINE) --validation $(DETECTOR_MN_DIR)/offline_report.json --sidecar-only

# Outside-in pinhole views (docs/DETECTOR_OUTSIDE.md): frames of
# DETECTOR_OUTSIDE_VIEWS cameras each, into $(DETECTOR_DIR)/outside/data.
DETECTOR_OUTSIDE_DIR ?= $(DETECTOR_DIR)/outside
DETECTOR_OUTSIDE_SEED ?= 3
DETECTOR_OUTSIDE_FRAMES ?= 6000
DETECTOR_OUTSIDE_FIRST ?= 0
DETECTOR_OUTSIDE_VIEWS ?= 4
DETECTOR_OUTSIDE_CHUNK ?= 250
DETECTOR_OUTSIDE_EPOCHS ?= 33
detector-data-outside:
	mkdir -p $(DETECTOR_OUTSIDE_DIR)/data $(DETECTOR_OUTSIDE_DIR)/logs
	n=$$(( $(DETECTOR_OUTSIDE_FRAMES) / $(DETECTOR_SHARDS) )); \
	for s in $$(seq 0 $$(( $(DETECTOR_SHARDS) - 1 ))); do \
	  ( f=$$(( $(DETECTOR_OUTSIDE_FIRST) + s * n )); e=$$(( f + n )); while [ $$f -lt $$e ]; do \
	      c=$$(( e - f < $(DETECTOR_OUTSIDE_CHUNK) ? e - f : $(DETECTOR_OUTSIDE_CHUNK) )); \
	      nice -n 10 $(BLENDER) -b --factory-startup --python tools/synth/render.py -- --kind outside \
	        --views $(DETECTOR_OUTSIDE_VIEWS) --out $(DETECTOR_OUTSIDE_DIR)/data --mocap $(MOCAP_TRAIN_DIR) \
	        --seed $(DETECTOR_OUTSIDE_SEED) --first $$f --count $$c 2>&1 | grep -a --line-buffered 'synth:' \
	        > $(DETECTOR_OUTSIDE_DIR)/logs/render_$$f.log || exit 1; \
	      f=$$(( f + c )); done ) & \
	done; wait; grep -h 'synth:' $(DETECTOR_OUTSIDE_DIR)/logs/render_*.log | tail -n 4

detector-train:
	nice -n 10 $(TRAIN_PYTHON) tools/train/train.py --data $(DETECTOR_DIR)/data \
	  --ckpt $(DETECTOR_DIR)/ckpt.pt --seed $(DETECTOR_SEED) --epochs $(DETECTOR_EPOCHS) --resume

# The outside-in model: one stage, from scratch (docs/DETECTOR.md,
# "Outside-in model").  DETECTOR_OUTSIDE_THREADS=2 only on otherwise idle
# cores: with the cores shared (a renderer, other builds) two torch threads
# ran at 9 views/s here, one at 55.
DETECTOR_OUTSIDE_THREADS ?= 1
detector-train-outside:
	nice -n 10 $(TRAIN_PYTHON) tools/train/train.py --kind outside --data $(DETECTOR_OUTSIDE_DIR)/data \
	  --ckpt $(DETECTOR_OUTSIDE_DIR)/ckpt.pt --seed $(DETECTOR_OUTSIDE_SEED) --epochs $(DETECTOR_OUTSIDE_EPOCHS) \
	  --threads $(DETECTOR_OUTSIDE_THREADS) --ckpt-minutes 2 --resume

# Optional stage 2 for the outside-in model (the shipped one is stage 1's
# best.pt): fine-tune stage 1's last checkpoint after more frames were
# rendered, as detector-finetune does for ego; then export with
# DETECTOR_OUTSIDE_WEIGHTS=$(DETECTOR_OUTSIDE_DIR)/stage2/best.pt.
DETECTOR_OUTSIDE_FT_EPOCHS ?= 12
detector-finetune-outside:
	mkdir -p $(DETECTOR_OUTSIDE_DIR)/stage2
	nice -n 10 $(TRAIN_PYTHON) tools/train/train.py --kind outside --data $(DETECTOR_OUTSIDE_DIR)/data \
	  --ckpt $(DETECTOR_OUTSIDE_DIR)/stage2/ckpt.pt --init $(DETECTOR_OUTSIDE_DIR)/ckpt.pt --seed 4 \
	  --epochs $(DETECTOR_OUTSIDE_FT_EPOCHS) --lr 1e-3 --warmup 100 --threads $(DETECTOR_OUTSIDE_THREADS) \
	  --ckpt-minutes 2 --resume

DETECTOR_OUTSIDE_WEIGHTS ?= $(DETECTOR_OUTSIDE_DIR)/best.pt

detector-export-outside:
	$(TRAIN_PYTHON) tools/train/train.py --kind outside --seed $(DETECTOR_OUTSIDE_SEED) \
	  --data-seed $(DETECTOR_OUTSIDE_SEED) --weights $(DETECTOR_OUTSIDE_WEIGHTS) \
	  --export $(DETECTOR_OUTSIDE_DIR)/outside_detector.onnx

detector-report-outside:
	$(TRAIN_PYTHON) tools/train/train.py --kind outside --weights $(DETECTOR_OUTSIDE_WEIGHTS) \
	  --outside $(or $(MOCAP_DATA_DIR),../shared/data)/outside --report \
	  --report-out $(DETECTOR_OUTSIDE_DIR)/report.json

# Stage 2 of the shipped model: fine-tune stage 1's last checkpoint (after
# more frames were rendered) with a new seed and a short cosine schedule.
detector-finetune:
	mkdir -p $(DETECTOR_DIR)/stage2
	nice -n 10 $(TRAIN_PYTHON) tools/train/train.py --data $(DETECTOR_DIR)/data \
	  --ckpt $(DETECTOR_DIR)/stage2/ckpt.pt --init $(DETECTOR_DIR)/ckpt.pt --seed 2 --epochs 24 \
	  --lr 1e-3 --warmup 100 --resume

DETECTOR_WEIGHTS ?= $(DETECTOR_DIR)/stage2/best.pt

detector-export:
	$(TRAIN_PYTHON) tools/train/train.py --data $(DETECTOR_DIR)/data --seed 2 --data-seed $(DETECTOR_SEED) \
	  --weights $(DETECTOR_WEIGHTS) --export config/models/ego_detector.onnx

# The 2D report of a head-mounted model (a checkpoint, or by default the
# shipped ONNX file through OpenCV DNN) on the dev clips and, when the v2
# data is there, on its held-out validation (docs/DETECTOR.md, "Accuracy").
DETECTOR_REPORT_MODEL ?= config/models/ego_detector.onnx
detector-report:
	mkdir -p $(DETECTOR_DIR)
	$(TRAIN_PYTHON) tools/train/train.py --weights $(DETECTOR_REPORT_MODEL) --ego $(MOCAP_EGO_DIR) \
	  --data $(DETECTOR_V2_DIR)/data --report --report-out $(DETECTOR_DIR)/report.json

# Pretrained networks converted from TensorFlow.js (make models-movenet).
include tools/convert/module.mk

# The pose prior (docs/TRACKER.md, "Pose prior"): a Gaussian mixture over the
# body model's joint angles, from mocap-train's motions (no rendering).
#   make pose-prior   export joints, fit joint angles, train, write config/models/pose_prior.json
# mocap-prior-fit is built with `all` (so that it keeps compiling) but not installed.
PRIOR_DIR ?= $(BUILD)/prior
PRIOR_FIT := $(BUILD)/train/mocap-prior-fit
all: $(PRIOR_FIT)
$(PRIOR_FIT): tools/prior/mocap-prior-fit.c $(CORE_LIB)
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(CORE_LIB) $(CORE_LIBS)

.PHONY: pose-prior
pose-prior: $(PRIOR_FIT)
	mkdir -p $(PRIOR_DIR)
	$(TRAIN_PYTHON) tools/prior/export_joints.py $(MOCAP_TRAIN_DIR) --stride 2 > $(PRIOR_DIR)/joints.txt
	$(PRIOR_FIT) config/models/default.json < $(PRIOR_DIR)/joints.txt > $(PRIOR_DIR)/poses.txt
	$(TRAIN_PYTHON) tools/prior/train_prior.py $(PRIOR_DIR)/poses.txt --out config/models/pose_prior.json

# Evaluation clips of our own, held out from the detectors' training by
# motion family (and, the "val" ones, build, garment and scene kind), into
# EVAL_CLIPS_DIR (the Makefile's, beside bench-heldout).
.PHONY: eval-clips
eval-clips:
	tools/synth/eval_clips.sh $(EVAL_CLIPS_DIR) $(BLENDER)
