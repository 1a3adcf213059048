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

#include "mc_error.h"
#include "mc_math.h"

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

#endif
