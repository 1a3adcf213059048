/* mc_motion: a database of recorded motion for motion graphs
 * (docs/MOTION_GRAPH.md).
 *
 * Every clip, whatever skeleton it was recorded with, is retargeted to one
 * skeleton: the 18 output joints of docs/CONVENTIONS.md, rooted at the
 * pelvis, with the bone lengths of the body model (or the default model's
 * built in).  Retargeting keeps each bone's direction from the source and
 * takes its length from the target skeleton; the pelvis trajectory is scaled
 * by the ratio of leg lengths.  Frames are resampled to the database's frame
 * rate and stored as joint positions in one world frame: metres, z up, the
 * floor at z = 0 (each clip's lowest foot joint over the clip).
 *
 * Plain data, no hidden state; a database is filled by mc_motion_db_add_*. */
#ifndef MC_MOTION_H
#define MC_MOTION_H

#include "base/mc_error.h"
#include "base/mc_math.h"
#include "body/mc_bvh.h"
#include "body/mc_model.h"

#include <stdbool.h>
#include <stddef.h>

#define MC_MOTION_JOINTS 18
#define MC_MOTION_NAME_MAX 128
#define MC_MOTION_CLASS_MAX 32

/* Joint indices of the retargeted skeleton (parents come first). */
enum {
	MC_MJ_PELVIS, MC_MJ_SPINE, MC_MJ_NECK, MC_MJ_HEAD_TOP,
	MC_MJ_LSHOULDER, MC_MJ_LELBOW, MC_MJ_LWRIST,
	MC_MJ_RSHOULDER, MC_MJ_RELBOW, MC_MJ_RWRIST,
	MC_MJ_LHIP, MC_MJ_LKNEE, MC_MJ_LANKLE, MC_MJ_LTOE,
	MC_MJ_RHIP, MC_MJ_RKNEE, MC_MJ_RANKLE, MC_MJ_RTOE,
};

typedef struct {
	int parent[MC_MOTION_JOINTS];
	mc_vec3 offset[MC_MOTION_JOINTS]; /* rest offset from the parent, world axes (z up), metres */
} mc_motion_skel;

/* The docs/CONVENTIONS.md name of joint j. */
const char *mc_motion_joint_name(int j);
/* The default body model's proportions (config/models/default.json). */
void mc_motion_skel_default(mc_motion_skel *s);
/* The proportions of a body model whose joints carry the CONVENTIONS names
 * (its rest pose; model axes x right, y down, z forward become world axes
 * x right, y forward, z up).  Errors name the missing joint. */
int mc_motion_skel_from_model(const mc_model *m, mc_motion_skel *s, mc_err *err);
/* Rest positions of every joint, pelvis at the origin. */
void mc_motion_skel_rest(const mc_motion_skel *s, mc_vec3 *pos);

typedef struct {
	char name[MC_MOTION_NAME_MAX];   /* the file's base name */
	char cls[MC_MOTION_CLASS_MAX];   /* motion class ("walk"), "" when none */
	int first, nframes;              /* frames [first, first + nframes) of the database */
} mc_motion_clip;

typedef struct {
	double fps;
	mc_motion_skel skel;
	int nclips;
	mc_motion_clip *clips;
	int nframes;
	mc_vec3 *pos;     /* nframes * MC_MOTION_JOINTS */
	int *clip_of;     /* nframes: the clip of each frame */
} mc_motion_db;

/* An empty database at fps frames per second with skeleton s. */
void mc_motion_db_init(mc_motion_db *db, double fps, const mc_motion_skel *s);
void mc_motion_db_free(mc_motion_db *db);
static inline const mc_vec3 *mc_motion_frame(const mc_motion_db *db, int f)
{
	return db->pos + (size_t)f * MC_MOTION_JOINTS;
}

/* Leading source frames whose joints move more than this to the next
 * frame (metres, after scaling) are dropped: a converter's stock pose. */
#define MC_MOTION_LEAD_JUMP_M 0.3

/* Adds a clip given as source joint positions, world axes z up, in any
 * length unit (scaled by the leg ratio): src[k * MC_MOTION_JOINTS + j] at
 * time k * src_dt.  It is retargeted, resampled and put on the floor. */
int mc_motion_db_add_positions(mc_motion_db *db, const char *name, const char *cls, const mc_vec3 *src, int nsrc,
			       double src_dt, mc_err *err);
/* Adds a BVH file with either CMU joint naming (body/mc_bvh.h) or the
 * naming of the Daz-friendly CMU conversion (hip, chest, lThigh, ...).  Leading
 * frames whose rotation channels are all zero (the converters' T-pose) are
 * skipped.  Errors name the file. */
int mc_motion_db_add_bvh(mc_motion_db *db, const char *path, const char *cls, mc_err *err);

/* ---- the floor frame of a pose ----
 * The usual motion-graph alignment (Kovar et al. 2002): a pose is compared
 * after a rotation about the vertical axis and a translation on the floor
 * that put its pelvis over the origin facing +y.  Heading: the horizontal
 * direction of (left_hip - right_hip) turned by -90 degrees about z. */
typedef struct {
	double x, y;     /* the pelvis on the floor */
	double heading;  /* radians, angle of the facing direction from +x */
} mc_floor_frame;

mc_floor_frame mc_motion_floor_frame(const mc_vec3 *pose);
/* world = R_z(heading - pi/2) * local + (x, y, 0) */
mc_vec3 mc_floor_to_world(mc_floor_frame f, mc_vec3 local);
mc_vec3 mc_floor_from_world(mc_floor_frame f, mc_vec3 world);
/* Re-imposes the skeleton's bone lengths on pose (from the root out),
 * keeping each bone's direction; the hips and the shoulders are set
 * rigidly in the frame of their parent (the pelvis, the neck), so that the
 * pose is one of the skeleton's: mc_motion_orientations then reproduces it
 * by forward kinematics. */
void mc_motion_fix_lengths(const mc_motion_skel *s, mc_vec3 *pose);

/* World orientations of every joint of a pose (after mc_motion_fix_lengths),
 * for output (skeleton streams, BVH): the rotation taking the rest
 * skeleton's frame of the joint to the pose's.  A joint's frame is built
 * from its bone to its first child (for the neck: the spine's direction,
 * the neck carrying the shoulders like a chest) and the body's left-right
 * line (hips for the legs and pelvis, shoulders for the upper body).  A
 * joint without children takes its parent's.  With these rotations and
 * the rest offsets, forward kinematics gives back every joint but head_top,
 * which needs a head joint at the neck turned by mc_motion_head_rotation. */
void mc_motion_orientations(const mc_motion_skel *s, const mc_vec3 *pose, mc_mat3 *R);
mc_mat3 mc_motion_head_rotation(const mc_motion_skel *s, const mc_vec3 *pose);

#endif
