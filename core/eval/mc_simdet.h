/* mc_simdet: a simulated 2D joint detector with the gross errors the
 * shipped detectors make (issue 35 item 1), for mocap-bench
 * --simulated-detector and tests; never the evaluation protocol.  The
 * named joints of frame k are projected from the ground truth into every
 * camera with Gaussian noise (noise_px native pixels per axis) and
 * MC_CLIP_SIMULATED_MISS of them missed, exactly as mc_clip_simulated_keypoints
 * always did (same random draws, so zero rates give the old keypoints);
 * then, per camera, each mode at its rate:
 *   collapse        per left/right pair with both keypoints: both channels
 *                   at one limb's position (either side, even odds)
 *   swap            per such pair: the two labels exchanged (one draw per
 *                   pair: collapsed, swapped or neither; the two rates
 *                   add up to at most 1)
 *   occluded_wrong  per kept keypoint of a paired joint hidden behind
 *                   another body part (mc_simdet_occluded): placed on the
 *                   other limb (its partner's projection, its own noise)
 *   outlier         per kept keypoint: moved 1.5-5x the far threshold
 *                   (mc_simdet_far_px) in a random direction; with persist
 *                   N > 1, drawn per camera and joint for runs of N frame
 *                   sets (each run's start offset per camera and joint), so
 *                   the same keypoint stays wrong, the same way, for the
 *                   run, as the shipped detectors' gross errors do
 *   blind_confidence  every confidence uniform in [0.3, 1], drawn alike for
 *                   good and wrong keypoints (else 1)
 * Deterministic for a given rng state. */
#ifndef MC_SIMDET_H
#define MC_SIMDET_H

#include "eval/mc_clip.h"

/* "More than 10 px off" at the shipped detectors' input scale, where their
 * gross errors were measured (128 wide head-mounted, 192 outside-in):
 * MC_SIMDET_FAR_PX * width / that width, in native pixels. */
#define MC_SIMDET_FAR_PX 10.0
#define MC_SIMDET_MAX_JOINTS 32

typedef struct {
	double noise_px;
	double collapse, swap, occluded_wrong, outlier;
	bool blind_confidence;
	int persist;   /* frame sets an outlier lasts (0 or 1: drawn afresh each frame set) */
	uint64_t seed; /* of the persistent outliers' draws (with persist > 1) */
} mc_simdet;

/* What a run produced, summed over calls (for the report and the tests). */
typedef struct {
	long keypoints, far;       /* kept keypoints; those > the far threshold from their truth */
	long pairs, collapsed, swapped;
	long occluded, occluded_wrong;
	long outliers;
} mc_simdet_stats;

/* Presets from the shipped detectors' measurements (docs/man/mocap-bench.1
 * gives the sources): "ego", "outside"; "none" zeroes every rate.  False
 * for an unknown name.  noise_px is left as it is. */
bool mc_simdet_preset(const char *name, mc_simdet *sd);

/* Frame k's keypoints of the named joints; stats (may be NULL) adds up. */
int mc_simdet_keypoints(const mc_clip *clip, const mc_model *m, const char *const *joints, int njoints, int k,
			const mc_simdet *sd, uint64_t *rng, mc_keypoint *kp, int cap, mc_simdet_stats *stats);

/* Whether ground-truth joint g of frame k is hidden from rig camera c by
 * another body part: a capsule around a bone of the truth (torso
 * neck-pelvis 14 cm, head 10 cm, upper arms 5, forearms 4.5, thighs 8,
 * shins 6, feet 4 cm radius) crosses the ray to it at least 5 cm before
 * the joint.  Bones that end at g do not count. */
bool mc_simdet_occluded(const mc_clip *clip, int k, int c, int g);

/* The far threshold of rig camera c in native pixels. */
double mc_simdet_far_px(const mc_clip *clip, int c);

#endif
