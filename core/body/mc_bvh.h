/* mc_bvh: Biovision Hierarchy (BVH) motion files.
 *
 * A BVH file holds a joint tree (HIERARCHY: ROOT, JOINT and End Site blocks
 * with OFFSET and CHANNELS) and a MOTION section (Frames, Frame Time, then
 * one line of channel values per frame).  Offsets and positions are in the
 * file's own units (the CMU conversions are not in metres: scale them to a
 * person's height); rotations are in degrees.
 *
 * Forward kinematics follows the usual reading of the format: a joint's
 * local transform is a translation by OFFSET plus its position channels,
 * then the rotations in the order the CHANNELS line lists them
 * (e.g. "Zrotation Yrotation Xrotation": R = Rz * Ry * Rx), and
 * world_from_joint = world_from_parent * local. */
#ifndef MC_BVH_H
#define MC_BVH_H

#include "base/mc_error.h"
#include "base/mc_math.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define MC_BVH_NAME_MAX 64
#define MC_BVH_MAX_JOINTS 512

typedef enum {
	MC_BVH_XPOS = 0,
	MC_BVH_YPOS = 1,
	MC_BVH_ZPOS = 2,
	MC_BVH_XROT = 3,
	MC_BVH_YROT = 4,
	MC_BVH_ZROT = 5,
} mc_bvh_channel;

typedef struct {
	char name[MC_BVH_NAME_MAX]; /* an End Site is named "<parent>_End" */
	int parent;                 /* -1 for a root; parents come before children */
	bool end_site;
	mc_vec3 offset;             /* from the parent, file units */
	int nchannels;              /* 0..6 */
	uint8_t channels[6];        /* mc_bvh_channel, in file order */
	int channel0;               /* index of the first of them in a frame's values */
} mc_bvh_joint;

typedef struct {
	int njoints;          /* ROOT and JOINT blocks and End Sites */
	mc_bvh_joint *joints;
	int nchannels;        /* values per frame */
	int nframes;
	double frame_time;    /* seconds */
	double *values;       /* nframes * nchannels, as in the file */
} mc_bvh;

/* Loads a file. Errors name the file and line, e.g.
 * "walk.bvh:12: CHANNELS: 'Wrotation' is not a channel name". */
int mc_bvh_load(const char *path, mc_bvh *bvh, mc_err *err);
/* Parses text (len bytes, need not be NUL-terminated); origin names it in errors. */
int mc_bvh_parse(const char *text, size_t len, const char *origin, mc_bvh *bvh, mc_err *err);
void mc_bvh_free(mc_bvh *bvh);

/* Index of a joint by name, or -1. */
int mc_bvh_find(const mc_bvh *bvh, const char *name);
/* ROOT and JOINT blocks only (End Sites not counted). */
int mc_bvh_count_joints(const mc_bvh *bvh);
/* Values of frame f (clamped to the valid range). */
const double *mc_bvh_frame(const mc_bvh *bvh, int frame);

/* Forward kinematics of one frame: world_from_joint[njoints], file units. */
void mc_bvh_fk(const mc_bvh *bvh, int frame, mc_xform *world_from_joint);

/* Height of the rest pose (every channel 0): the extent along +y (up in
 * BVH) over all joints and end sites, in file units.  actor height /
 * this = metres per file unit. */
double mc_bvh_rest_height(const mc_bvh *bvh);

/* ---- the CMU skeletons under the joint names of docs/CONVENTIONS.md ----
 *
 * The CMU database in B. Hahne's BVH conversion comes with two joint
 * namings (131_01.bvh and 01_01.bvh in shared/data/mocap); both map:
 *
 *   docs/CONVENTIONS.md        older naming (131_01)   newer naming (01_01)
 *   head_top         Head_End                Head_End
 *   neck             Head                    Head        (base of the skull)
 *   spine            Chest                   Spine1      (differs; not evaluated)
 *   pelvis           Hips                    Hips
 *   left_shoulder    LeftShoulder            LeftArm     (01_01's LeftShoulder is the clavicle)
 *   left_elbow       LeftElbow               LeftForeArm
 *   left_wrist       LeftWrist               LeftHand
 *   left_hip         LeftHip                 LeftUpLeg
 *   left_knee        LeftKnee                LeftLeg
 *   left_ankle       LeftAnkle               LeftFoot
 *   left_toe         LeftToe                 LeftToeBase
 *   right_*          the same with Right
 *
 * The naming is told apart by the presence of LeftUpLeg.  Scaled by
 * mc_bvh_rest_height and expressed in the Head joint's frame, these
 * positions match shared/data/ego/<clip>/gt.json up to one rigid transform
 * per clip (the helmet's pose on the head), to below a millimetre. */
#define MC_BVH_CMU_JOINTS 18

/* The docs/CONVENTIONS.md name of mapped joint i (0 .. MC_BVH_CMU_JOINTS-1). */
const char *mc_bvh_cmu_joint_name(int i);

/* Finds the BVH joint of every mapped joint: bvh_index[MC_BVH_CMU_JOINTS].
 * Errors name the first joint that is missing, and the Head joint. */
int mc_bvh_map_cmu(const mc_bvh *bvh, int *bvh_index, mc_err *err);

/* Positions of the mapped joints at one frame relative to the skeleton's
 * Head joint, in metres (file units * metres_per_unit), in head axes turned
 * to the body model's root convention: x to the actor's right, y down, z
 * forward (BVH rest axes are x left, y up, z forward).  bvh_index comes
 * from mc_bvh_map_cmu; out holds MC_BVH_CMU_JOINTS positions. */
void mc_bvh_joints_in_head(const mc_bvh *bvh, const int *bvh_index, int frame, double metres_per_unit,
			   mc_vec3 *out);

#endif
