/* mc_tracker: per-frame pose tracking, the API the daemon and the benchmark use.
 *
 * Create a tracker from a rig, a model and settings; initialise it with a
 * pose (and optionally calibrate the actor's colours); then feed one
 * multi-view frame set per instant and read back the skeleton. */
#ifndef MC_TRACKER_H
#define MC_TRACKER_H

#include "base/mc_error.h"
#include "body/mc_model.h"
#include "geom/mc_rig.h"

#include <stdint.h>

typedef enum {
	MC_BACKEND_OPENCL = 0, /* the runtime default */
	MC_BACKEND_REFERENCE = 1,
} mc_backend;

typedef enum {
	MC_TRACK_OK = 0,
	MC_TRACK_UNCERTAIN = 1,
	MC_TRACK_LOST = 2,
	/* waiting for detections that a body fits (mc_tracker_start_from_detections);
	 * 3 is the status message's "idle" */
	MC_TRACK_INITIALISING = 4,
} mc_track_state;

typedef struct {
	mc_backend backend;
	int width, height;       /* working resolution per camera */
	int iterations;          /* gradient iterations per frame */
	double pixel_fraction;   /* share of valid pixels sampled per iteration */
	double dropout;          /* probability of dropping a Gaussian per pixel */
	double step;             /* base step size */
	double momentum;         /* 0..1 */
	double lambda_detection, lambda_limit, lambda_pose, lambda_smooth;
	/* Weight of the colour term (1).  0 drops it: the pose then follows the
	 * detections and the priors alone (for measuring what each term does). */
	double lambda_color;
	/* Pull toward the pose set by mc_tracker_set_pose / init_from_joints
	 * (the calibration pose), same pseudo-Huber form as lambda_smooth:
	 * keeps weakly observed dofs from random-walking (docs/TRACKER.md). */
	double lambda_anchor;
	/* Weight of the learned pose prior (mc_tracker_load_pose_prior); no
	 * effect while none is loaded.  0 by default (on head-mounted rigs it
	 * measured worse), 1e-3 on outside-in rigs (mc_tracker_outside_in). */
	double lambda_prior;
	/* Outside-in rigs (world frame z up, floor at z = 0): weight of the
	 * floor prior, a squared penalty on every Gaussian reaching below the
	 * floor (its centre less one sigma), so that no foot sinks into it.
	 * 0: off.  Ignored on head-mounted rigs, whose frame has no floor. */
	double lambda_floor;
	/* Re-fit the pose to the triangulated detections when the state is
	 * lost or a confident joint keeps disagreeing with the pose. */
	bool recover;
	/* Match each view's left/right keypoint pairs to the tracked pose's
	 * two joints by the cheaper assignment instead of trusting the
	 * detector's labels; a pair collapsed onto one peak pulls only the
	 * nearer joint (docs/TRACKER.md, "Sides").  Off by default, on for
	 * outside-in rigs (mc_tracker_outside_in). */
	bool assign_sides;
	/* After the actor's size (one scale for every bone) is measured from
	 * the detections, scale the upper arms, forearms, thighs and shins
	 * on their own, each pair within 10 % of that size (docs/TRACKER.md,
	 * "Starting without ground truth"). */
	bool fit_limbs;
	/* Before the iterations, fit the predicted pose to the frame set's
	 * keypoint rays (held to the prediction, robust) and keep each limb
	 * of that fit whose colour energy is lower (docs/TRACKER.md, "The ray
	 * fit").  On by default; outside-in only with 3 cameras or more
	 * (mc_tracker_outside_in). */
	bool ray_fit;
	/* The keypoint term's weight grows up to this factor (1: fixed) while
	 * the cameras' keypoints of one joint agree closely: lambda_detection
	 * holds for a detector whose views miss each other by 1.75 px at 128
	 * wide or more (the shipped head-rig detector), and a detector whose views agree
	 * within a fraction of that gets the weight its noise warrants, as
	 * 1 / noise^2 (docs/TRACKER.md, "Trusting keypoints that agree"). */
	double detection_trust_max;
	/* The share (0..1) of each camera's colour gradient that would move a
	 * Gaussian nearer that camera along its line of sight, dropped: one
	 * image places a Gaussian across its view, and along it the colour
	 * term mostly rewards a nearer Gaussian for covering more pixels that
	 * resemble its colour (docs/TRACKER.md, "Colours along the line of
	 * sight").  0.5 on a head rig; 0 (the thesis' gradient) on outside-in
	 * rigs. */
	double color_sight_cut;
	/* Where the tracking, not the detector, sets the pace (the head rig):
	 * the share (0..1] of pixel_fraction that the first three quarters
	 * of a frame set's iterations sample, and of the pixels near a part
	 * that the ray fit's colour check evaluates.  0.5 and 0.15 on a head
	 * rig; 1 and 0.3 on outside-in rigs (docs/TRACKER_MEASUREMENTS.md,
	 * "Speed (stop 57)"). */
	double early_pixel_share, check_pixel_share;
	int cl_platform, cl_device; /* -1: first GPU, else first CPU */
	uint64_t seed;
} mc_tracker_settings;

void mc_tracker_settings_default(mc_tracker_settings *s);
/* The settings that differ on outside-in rigs, where the whole body moves
 * through the world and the images are mostly background (docs/TRACKER.md,
 * "Outside-in rigs"): a weaker smoothness prior, and iterations shared out
 * so that a frame set costs the same whatever the number of cameras
 * (mc_tracker_outside_in_iterations).  Callers apply them to the settings
 * the user did not set. */
typedef struct {
	int camera_iterations;               /* iterations x cameras per frame set */
	int min_iterations, max_iterations;  /* the bounds of the share */
	double lambda_smooth, lambda_floor;
	double lambda_detection;             /* 0.3: measured with MoveNet and sides (docs/BENCHMARKS.md) */
	bool assign_sides;                   /* the views can settle left and right */
	double lambda_prior;                 /* the learned pose prior helps here */
	int ray_fit_min_cameras;             /* the ray fit with this many cameras or more */
	double detection_trust_max;          /* with trust_min_cameras or more (else 1: fixed) */
	int trust_min_cameras;
	double pixel_fraction;               /* the detector, not the pixels, sets the pace here */
	double color_sight_cut;              /* 0: the thesis' gradient (0.5 measured mixed) */
	double early_pixel_share, check_pixel_share; /* the head rig's cost more here */
} mc_tracker_outside_in_defaults;
extern const mc_tracker_outside_in_defaults mc_tracker_outside_in;
/* camera_iterations / ncams, within [min_iterations, max_iterations]: 80
 * with four cameras, 160 with two. */
int mc_tracker_outside_in_iterations(int ncams);
/* The settings the user gave (a config key, a command-line option), which
 * the outside-in values leave alone. */
#define MC_GIVEN_ITERATIONS 1u
#define MC_GIVEN_LAMBDA_SMOOTH 2u
#define MC_GIVEN_LAMBDA_FLOOR 4u
#define MC_GIVEN_LAMBDA_DETECTION 8u
#define MC_GIVEN_ASSIGN_SIDES 16u
#define MC_GIVEN_LAMBDA_PRIOR 32u
#define MC_GIVEN_RAY_FIT 64u
#define MC_GIVEN_DETECTION_TRUST 128u
#define MC_GIVEN_PIXEL_FRACTION 256u
#define MC_GIVEN_COLOR_SIGHT_CUT 512u
/* Sets the outside-in values for a rig of ncams cameras in every setting
 * not in `given` (MC_GIVEN_* flags). */
void mc_tracker_settings_outside_in(mc_tracker_settings *s, int ncams, unsigned given);
const char *mc_track_state_name(mc_track_state s);

/* One camera's image: packed RGB24, any resolution (scaled to the working
 * resolution). rgb == NULL means the camera is missing from this frame set. */
typedef struct {
	int width, height, stride;
	const uint8_t *rgb;
	uint64_t timestamp_ns;
} mc_frame_view;

/* Optional external 2D keypoints for one frame set. */
typedef struct {
	int cam;           /* rig camera index */
	int joint;         /* model joint index */
	double u, v;       /* native pixels */
	double conf;       /* 0..1 */
} mc_keypoint;

typedef struct {
	char name[MC_JOINT_NAME_MAX];
	int parent;
	mc_vec3 position;   /* rig frame, metres */
	mc_quat orientation; /* rig_from_joint rotation */
	float confidence;   /* 0..1 */
} mc_skeleton_joint;

typedef struct {
	uint64_t timestamp_ns;
	mc_track_state state;
	int njoints;
	mc_skeleton_joint joints[MC_MAX_JOINTS];
	double energy;      /* final data energy per sampled pixel */
	double track_ms;    /* time spent in mc_tracker_track */
	int iterations;
} mc_skeleton;

typedef struct mc_tracker mc_tracker;

/* On an outside-in rig, a model with a fixed root is given a free one
 * (mc_model_make_root_free): its pose then has six more dofs in front. */
mc_tracker *mc_tracker_create(const mc_rig *rig, const mc_model *model, const mc_tracker_settings *s,
			      mc_err *err);
void mc_tracker_destroy(mc_tracker *t);

/* Changes the per-frame budget of a running tracker (e.g. on a config
 * reload), checked like mc_tracker_create's settings.  The actor, its
 * calibration, the pose and the device are kept. */
int mc_tracker_set_budget(mc_tracker *t, int iterations, double pixel_fraction, double dropout, double step,
			  double momentum, mc_err *err);

/* Sets the current pose (and history) to `pose` (model->ndof values). */
void mc_tracker_set_pose(mc_tracker *t, const double *pose);
const double *mc_tracker_pose(const mc_tracker *t);
/* The factor on lambda_detection now, in [1, detection_trust_max], and
 * the cameras' recent disagreement it comes from (pixels of an image 128
 * wide; 0 before any frame set had a joint seen by two cameras). */
double mc_tracker_keypoint_trust(const mc_tracker *t, double *spread_px);
const mc_model *mc_tracker_model(const mc_tracker *t);

/* Initialises from 3D joint positions (rig frame, metres), e.g. the ground
 * truth of frame 0 or a detector's output: a small inverse-kinematics solve
 * for the bone-length scales, the root placement (rig_from_root for fixed
 * roots) and the pose, by the limb joints and neck first
 * (body/mc_fit_joints.h).  names[i] is a model joint name; unknown names are
 * ignored.  Resets the pose history. */
int mc_tracker_init_from_joints(mc_tracker *t, const char *const *names, const mc_vec3 *positions, int n,
				mc_err *err);

/* Starts without any pose: until a frame set's keypoints (two or more
 * cameras per joint that agree) fit a body, mc_tracker_track reports
 * MC_TRACK_INITIALISING with the rest pose.  The first fit sets the pose
 * and the colours from that frame set (with MC_INIT_KEEP_ACTOR, the model's
 * colours are kept); with MC_INIT_MEASURE_SIZE, the actor's size
 * (one scale of the model's bones) is then found from a few of the next
 * frame sets' detections, and the colours are measured again
 * (docs/TRACKER.md, "Starting without ground truth").  Returns -1 with err
 * when out of memory. */
#define MC_INIT_MEASURE_SIZE 1u /* measure the actor's size (outside-in rigs only) */
#define MC_INIT_KEEP_ACTOR 2u   /* the model is an actor file: keep its size and colours */
int mc_tracker_start_from_detections(mc_tracker *t, unsigned flags, mc_err *err);

/* Counts the tracker's calibrations: a new value means the actor in use
 * (mc_tracker_model: bone scales, head placement, colours) changed or, from
 * an actor file, started, e.g. for saving it as an actor file
 * (mc_model_save).  0: never calibrated. */
unsigned mc_tracker_actor_version(const mc_tracker *t);

typedef struct {
	bool initialising;   /* no pose yet */
	bool shape_measured; /* the actor's size set from detections */
	int shape_frames;    /* frame sets collected for them */
	int inits, refits;   /* first fits, and re-fits (recoveries) since the start */
	int refit_tries;     /* re-fits tried since the start, kept or not */
	int turns;           /* times the body was turned around (docs/TRACKER.md, "Facing") */
	int joints_triangulated; /* in the last frame set */
	double scale;        /* the actor's size found, as a bone scale (0 before) */
} mc_tracker_init_info;
void mc_tracker_get_init_info(const mc_tracker *t, mc_tracker_init_info *out);

/* Estimates each Gaussian's colour from one frame set at the current pose:
 * visibility-weighted mean of its pixels, the worst 50% dropped (thesis 5.3.2). */
int mc_tracker_calibrate_colors(mc_tracker *t, const mc_frame_view *views, int nviews, mc_err *err);

/* Tracks one frame set (nviews == rig->ncams; a view with rgb == NULL is a
 * missing camera). Keypoints may be NULL. */
int mc_tracker_track(mc_tracker *t, const mc_frame_view *views, int nviews, const mc_keypoint *kp, int nkp,
		     mc_skeleton *out, mc_err *err);

/* Keypoints that come while a frame set is being tracked: a detector that
 * runs beside the tracker finishes a few milliseconds into the tracking of
 * its frame set, and waiting for it would delay every pose.  When set, the
 * tracker calls poll before each gradient iteration of mc_tracker_track
 * (`iteration` counts from 0); it writes the keypoints of this frame set
 * that came since its last call into kp (at most cap) and returns their
 * count, 0 when none came.  They join the keypoint term from that
 * iteration on (and the check across cameras is made again with them).
 * The start from detections runs before the iterations and sees only the
 * keypoints given to mc_tracker_track.  The re-fit of a lost or stuck pose
 * and the actor's size, which triangulate across cameras, also run before
 * them when every view came with keypoints; else they run after the
 * iterations with those that came (a re-fit there beat the tracked pose
 * on the frame set's images and is the pose returned for it, and the next
 * frame set's start).  NULL: no polling. */
/* Loads the learned pose prior (config/models/pose_prior.json,
 * mc_pose_prior.h) for the tracker's model; its term, weighted by
 * settings.lambda_prior, joins every iteration's energy.  A second load
 * replaces the first.  -1 with err naming the file. */
int mc_tracker_load_pose_prior(mc_tracker *t, const char *path, mc_err *err);

typedef int (*mc_keypoint_poll)(void *ctx, int iteration, mc_keypoint *kp, int cap);
void mc_tracker_set_keypoint_poll(mc_tracker *t, mc_keypoint_poll poll, void *ctx);
/* A ready-made poll for measuring and testing keypoints that come late:
 * with a mc_keypoints_at as its ctx, it hands over the nkp keypoints at kp
 * once, before iteration `at` (kp must live until mc_tracker_track
 * returns; nkp is 0 after). */
typedef struct {
	const mc_keypoint *kp;
	int nkp, at;
} mc_keypoints_at;
int mc_keypoints_at_poll(void *ctx, int iteration, mc_keypoint *kp, int cap);

/* Name of the compute device in use, e.g. "pocl: pthread-skylake". */
const char *mc_tracker_device_name(const mc_tracker *t);

#endif
