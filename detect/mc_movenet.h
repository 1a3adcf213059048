/* mc_movenet: decoding the raw heads of a MoveNet single-pose network
 * (Google's, converted by tools/convert/tfjs_to_onnx.py), and the square
 * crop of the runtime's second pass (plain C, no OpenCV).
 *
 * The converted network stops before MoveNet's own post-processing (argmax
 * and gathers, which OpenCV 4.6 cannot import), so this file does it,
 * exactly as the TensorFlow.js graph does (docs/DETECT_RUNTIME.md,
 * "MoveNet"):
 *   1. the person: the argmax of the centre map weighted by
 *      1 / (distance to the map's centre cell (H/2, W/2) + 1.8);
 *   2. each joint's rough place: that cell plus the joint's regression
 *      there (channels 2j: rows, 2j + 1: columns);
 *   3. each joint: the argmax of its heatmap weighted by
 *      1 / (distance to the rough place + 1.8), plus the joint's offset at
 *      that cell; its score is the unweighted heatmap there.
 * The weighting is what makes it pick the person nearest the image centre
 * and not a bystander's wrist. */
#ifndef MC_MOVENET_H
#define MC_MOVENET_H

/* The four heads of one image, planar (NCHW without the batch). */
typedef struct {
	const float *heatmaps; /* J x H x W, in [0, 1] */
	const float *centers;  /* 1 x H x W, in [0, 1] */
	const float *regress;  /* 2J x H x W, cells */
	const float *offsets;  /* 2J x H x W, cells */
	int njoints, height, width;
} mc_movenet_heads;

/* A joint in the network's input, as fractions of its height and width
 * (MoveNet's own output convention), and its score. */
typedef struct {
	float y, x, score;
} mc_movenet_point;

/* The pose the heads hold: out[0..njoints-1]. */
void mc_movenet_decode(const mc_movenet_heads *heads, mc_movenet_point *out);

/* One limb under both labels: where a left/right pair's two joints were
 * decoded within MC_MOVENET_PAIR_CELLS cells of each other, and the
 * regressed place of one of them (the one farther from that spot) lies
 * more than MC_MOVENET_PAIR_EXCLUDE cells away, that joint moves to its
 * heat map's best other peak: a local maximum more than
 * MC_MOVENET_PAIR_EXCLUDE cells from the spot, nearer its regressed place
 * than the spot is, weighted as the decoding weighs, of min_score or more.
 * It keeps the pair's score.  With no such peak both stay.  MoveNet puts
 * one leg of a faceless mannequin under both labels where the other leg is
 * plain to see; its heat map and its regression usually hold that other
 * leg (docs/DETECT_RUNTIME.md, "MoveNet"). */
#define MC_MOVENET_PAIR_CELLS 1.5f
#define MC_MOVENET_PAIR_EXCLUDE 2.5f
void mc_movenet_separate_pairs(const mc_movenet_heads *heads, float min_score, mc_movenet_point *out);

/* A square region of a native image, pixels; it may reach outside the image
 * (that part is black in the network's input). */
typedef struct {
	float x0, y0, size;
} mc_movenet_square;

/* The square that letterboxes a whole width x height image. */
mc_movenet_square mc_movenet_full_square(int width, int height);

/* The square for a second look at the person, from joints in native pixels
 * (xy[2j], xy[2j + 1]; score[j]) with COCO's order of the 17 MoveNet joints:
 * centred on the hips, wide enough for 1.9x the torso and 1.2x the farthest
 * joint seen (MoveNet's own cropping rule).  Returns 0, or -1 when a hip
 * or a shoulder is not seen with min_score (then there is no second look). */
int mc_movenet_person_square(const float *xy, const float *score, int njoints, float min_score,
			     mc_movenet_square *out);

#endif
