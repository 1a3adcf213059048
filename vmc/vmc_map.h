/* vmc_map: mocapd's skeleton as the Unity humanoid bones of the VMC
 * protocol (docs/VMC.md, "Bones" and "Rotations").
 *
 * A bone sits at one skeleton joint (its position joint) and turns with the
 * frame of one joint (its rotation joint): the joint whose frame carries
 * the segments to the bone's children.  For a skeleton rooted at the head
 * (mocapd's models) the spine bones turn with the joint above them, since
 * the skeleton's tree runs from the head down; for one rooted at the pelvis
 * each bone turns with its own joint.
 *
 * Rotations are Unity local rotations relative to a rest pose: the T-pose of
 * Unity humanoids (arms out to the sides, legs straight down), or the
 * skeleton's own rest pose (every joint frame aligned with its parent's).
 * With the bones' local positions from the same rest pose, Unity's forward
 * kinematics from the Hips reproduces the skeleton's joint positions.
 *
 * Plain data and pure functions: no allocation, no I/O except loading a
 * bone table file. */
#ifndef VMC_MAP_H
#define VMC_MAP_H

#include "base/mc_error.h"
#include "base/mc_math.h"
#include "mocap.h"

#include <stdbool.h>

/* The Unity HumanBodyBones VMC sends, parents before children. */
typedef enum {
	VMC_HIPS,
	VMC_SPINE,
	VMC_CHEST,
	VMC_UPPER_CHEST,
	VMC_NECK,
	VMC_HEAD,
	VMC_LEFT_SHOULDER,
	VMC_LEFT_UPPER_ARM,
	VMC_LEFT_LOWER_ARM,
	VMC_LEFT_HAND,
	VMC_RIGHT_SHOULDER,
	VMC_RIGHT_UPPER_ARM,
	VMC_RIGHT_LOWER_ARM,
	VMC_RIGHT_HAND,
	VMC_LEFT_UPPER_LEG,
	VMC_LEFT_LOWER_LEG,
	VMC_LEFT_FOOT,
	VMC_LEFT_TOES,
	VMC_RIGHT_UPPER_LEG,
	VMC_RIGHT_LOWER_LEG,
	VMC_RIGHT_FOOT,
	VMC_RIGHT_TOES,
	VMC_NBONES
} vmc_bone_id;

/* "Hips", "LeftUpperArm", ... (Unity's names); -1 / NULL when unknown. */
const char *vmc_bone_name(int bone);
int vmc_bone_find(const char *name);
/* The bone's parent in Unity's humanoid hierarchy (-1 for the Hips). */
int vmc_bone_unity_parent(int bone);

/* Which skeleton joint each bone sits at and which joint's frame turns it,
 * by name; "" = the bone is not sent (pos) or the rotation joint is chosen
 * automatically (rot). */
typedef struct {
	char pos[VMC_NBONES][MOCAP_NAME_MAX];
	char rot[VMC_NBONES][MOCAP_NAME_MAX];
	bool given[VMC_NBONES]; /* named by a bone file: the joint must exist */
} vmc_bone_table;

/* The table for the project's joint names (docs/CONVENTIONS.md). */
void vmc_bone_table_default(vmc_bone_table *t);
/* Applies a bone file (INI, section [bones]: `Bone = joint [rotation_joint]`,
 * an empty value drops the bone) on top of t.  Errors name the file, line
 * and key. */
int vmc_bone_table_load(vmc_bone_table *t, const char *path, mc_err *err);

typedef enum {
	VMC_REST_TPOSE = 0, /* rotations relative to Unity's T-pose (what receivers expect) */
	VMC_REST_MODEL = 1, /* relative to the skeleton's rest pose */
} vmc_rest;

#define VMC_MAX_CONF_JOINTS 8

typedef struct {
	int id;        /* vmc_bone_id */
	int parent;    /* index in vmc_map.bone, -1 for the Hips */
	int pos_joint, rot_joint;
	int conf_joint[VMC_MAX_CONF_JOINTS]; /* joints whose confidence the bone's rotation rests on */
	int nconf;
	mc_mat3 tpose;     /* the bone's rest-to-T-pose turn, in the skeleton's rest frame */
	mc_vec3 local_pos; /* Unity local position in the parent bone (not for the Hips) */
	mc_quat rest_local; /* Unity local rotation of the skeleton's rest pose */
} vmc_bone;

typedef struct {
	uint32_t skeleton_id;
	int nbones;
	vmc_bone bone[VMC_NBONES]; /* bone[0] is the Hips */
	/* Unity bone axes (x right, y up, z forward) to the skeleton's joint
	 * axes: columns are the body's right, up and forward at rest, found
	 * from the rest offsets (legs or arms for right, Hips to Head for up).
	 * A reflection: Unity is left-handed. */
	mc_mat3 body_from_unity;
} vmc_map;

/* Maps the skeleton's joints to bones.  Fails, naming the bone, when the
 * Hips or a named joint is missing, or the rest pose has no up or right. */
int vmc_map_build(vmc_map *m, const mocap_skeleton_def *sk, const vmc_bone_table *t, vmc_rest rest, mc_err *err);

/* The world VMC sends, as seen from the frame's space. */
typedef enum {
	VMC_UP_Y,    /* y up, -z forward, right-handed (OpenXR: a VR runtime's world) */
	VMC_UP_Z,    /* z up, right-handed (outside-in rigs: docs/RIG_FORMAT.md) */
	VMC_UP_HEAD, /* the root joint (the head) held upright, e.g. a head-mounted rig's own frame */
} vmc_up;

/* Unity world coordinates from the frame's space (a reflection). */
mc_mat3 vmc_unity_from_space(const vmc_map *m, const mocap_skeleton_frame *f, vmc_up up);

typedef struct {
	mc_vec3 pos;      /* Unity: the Hips' world position, other bones their local position */
	mc_quat rot;      /* Unity local rotation (the Hips': world) */
	float confidence; /* the lowest of its conf_joint */
} vmc_bone_pose;

/* The frame as bone poses (out[i] for m->bone[i]); floor_height: the
 * floor's height along the up axis in the frame's space. */
void vmc_map_pose(const vmc_map *m, const mocap_skeleton_frame *f, vmc_up up, double floor_height,
		  vmc_bone_pose *out);

/* Largest distance (m) between a joint position from Unity forward
 * kinematics of `poses` and the frame's own, over every bone: 0 up to
 * rounding when the rotation joints carry the bones' children rigidly. */
double vmc_map_residual(const vmc_map *m, const mocap_skeleton_frame *f, vmc_up up, double floor_height,
			const vmc_bone_pose *poses);

/* What a bone does while its confidence is below the threshold. */
typedef enum {
	VMC_LOW_HOLD = 0, /* keep the last good rotation */
	VMC_LOW_REST = 1, /* ease to the rest pose's rotation */
} vmc_low;

typedef struct {
	bool have[VMC_NBONES];
	mc_quat last[VMC_NBONES];
	mc_vec3 hips_pos;
	uint64_t t_ns;
} vmc_hold;

/* Replaces the rotations of low-confidence bones (and the Hips position
 * while the Hips are low) by the held or eased ones; t_ns: the frame's
 * time, for the easing's time constant ease_s. */
void vmc_hold_apply(vmc_hold *h, const vmc_map *m, vmc_bone_pose *poses, float min_confidence, vmc_low mode,
		    double ease_s, uint64_t t_ns);

#endif
