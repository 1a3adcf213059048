/* mc_tracker_internal: the tracker's state and the helpers that the
 * tracking loop (mc_tracker.c) and the actor calibration (mc_calibrate.c)
 * share.  Not part of the public API. */
#ifndef MC_TRACKER_INTERNAL_H
#define MC_TRACKER_INTERNAL_H

#include "energy/mc_cl.h"
#include "body/mc_pose_prior.h"
#include "energy/mc_energy.h"
#include "track/mc_tracker.h"

/* One frame set's keypoints triangulated per joint (mc_init.c). */
typedef struct {
	bool have[MC_MAX_JOINTS];
	mc_vec3 pos[MC_MAX_JOINTS];
	double conf[MC_MAX_JOINTS];
	int nray[MC_MAX_JOINTS]; /* the rays that met, per joint */
	struct {
		mc_vec3 origin, dir;
		double weight;
	} ray[MC_MAX_JOINTS][MC_MAX_CAMERAS];
	int n, torso;
} mc_trk_triangulation;

/* Frame sets whose keypoints' agreement sets the keypoint term's trust
 * (mc_keypoint_trust.c): 3 s at 30 fps */
#define MC_TRK_TRUST_FRAMES 90

/* The facing checks' log(exchanged labels' RMS / kept labels' RMS), the
 * last MC_TRK_FACING_CHECKS (mc_facing.c). */
#define MC_TRK_FACING_CHECKS 10
typedef struct {
	double log_ratio[MC_TRK_FACING_CHECKS];
	int n, next;
} mc_trk_facing;

/* Left/right pairs' widths (the shoulders') measured from the detections
 * on a head rig (mc_widths.c): each pair's triangulated distance across
 * the line of sight in the first MC_TRK_WIDTH_FRAMES frame sets with
 * keypoints after the first pose. */
#define MC_TRK_WIDTH_FRAMES 30 /* 1 s at 30 fps */
#define MC_TRK_WIDTH_PAIRS 2
typedef struct {
	bool measure;  /* measuring: started from detections, no actor file */
	int frames;    /* frame sets seen since the first pose */
	int npairs, left[MC_TRK_WIDTH_PAIRS];
	int n[MC_TRK_WIDTH_PAIRS];
	double sample[MC_TRK_WIDTH_PAIRS][MC_TRK_WIDTH_FRAMES];
} mc_trk_widths;

/* Initialisation, shape calibration and recovery from detections
 * (mc_init.c). */
#define MC_TRK_SHAPE_FRAMES 10 /* frame sets whose detections set the actor's size */
typedef struct {
	bool waiting;    /* no pose yet: the state is initialising */
	bool fit_shape;  /* measure the actor's size */
	bool keep_colours; /* the colours came with the model (an actor file) */
	bool shape_done; /* size set from the collected frame sets */
	int nshape;      /* frame sets collected */
	int since_shape; /* frame sets since the last one collected */
	mc_trk_triangulation *shape_tri; /* MC_TRK_SHAPE_FRAMES, malloc'ed */
	double shape_pose[MC_TRK_SHAPE_FRAMES][MC_MAX_DOF]; /* tracked pose of each */
	bool collected;  /* this frame set was collected (its pose is stored after tracking) */
	int disagree[MC_MAX_JOINTS]; /* frame sets in a row a joint missed its rays */
	int caught[MC_MAX_JOINTS];   /* frame sets in a row a joint sat caught at the cameras */
	float conf[MC_MAX_JOINTS];   /* last frame set's joint confidence */
	int lost_run;    /* frame sets in a row in the lost state */
	int inits, refits, refit_tries, turns;
	mc_trk_facing facing;
	int last_joints;  /* joints triangulated in the last frame set */
	double scale;     /* the size found (uniform bone scale), 0 before */
	mc_trk_widths widths;
} mc_trk_init;

struct mc_tracker {
	mc_rig rig;
	mc_model model;
	int other_side[MC_MAX_JOINTS]; /* each joint's left/right partner, -1 for none */
	mc_tracker_settings s;
	mc_raytable rays[MC_MAX_CAMERAS];
	float *rgb[MC_MAX_CAMERAS]; /* working-resolution RGB of the current views */
	float *hsv[MC_MAX_CAMERAS];
	bool present[MC_MAX_CAMERAS];
	int *candidates[MC_MAX_CAMERAS];
	int ncandidates[MC_MAX_CAMERAS];
	int *samples[MC_MAX_CAMERAS];
	int nsamples[MC_MAX_CAMERAS];
	unsigned char *mask;
	mc_vec3 *jacobian; /* max(ngauss, MC_MAX_JOINTS) x ndof */
	bool hidden[MC_MAX_GAUSSIANS]; /* left out of the image energy */
	/* joints rigidly attached to a root fixed to the rig (the head on an
	 * egocentric rig): their position is known without any image */
	bool fixed_joint[MC_MAX_JOINTS];
	/* joints whose keypoints do not pull them (mc_trk_find_unpulled) */
	bool unpulled[MC_MAX_JOINTS];
	mc_cl_energy *cl;
	char device[160];

	double pose[MC_MAX_DOF];
	double prev[MC_MAX_DOF], prev2[MC_MAX_DOF];
	double anchor[MC_MAX_DOF]; /* calibration pose, for lambda_anchor */
	/* the background colour model of the energy (calibrate_background) */
	bool has_background;
	double background_hsv[3];
	/* per Gaussian: its image evidence at calibration
	 * (mc_trk_gaussian_evidence), the reference for confidence */
	double evidence0[MC_MAX_GAUSSIANS];
	int history; /* frames of history in prev/prev2 (0..2) */
	double baseline; /* mean data energy per pixel after calibration (< 0) */
	mc_trk_init init;
	unsigned actor_version; /* counts calibrations (mc_trk_calibrate) */
	uint64_t rng;
	/* keypoints arriving during mc_tracker_track (mc_tracker_set_keypoint_poll) */
	mc_keypoint_poll kp_poll;
	void *kp_poll_ctx;
	struct mc_trk_frame_keypoints *fkp;
	/* the last frame sets' median gap between two cameras' rays of one
	 * joint (a ring: kp_nspreads of them, the next written at kp_next;
	 * mc_trk_update_trust), and the median of those; 0: none yet */
	double kp_spreads[MC_TRK_TRUST_FRAMES];
	int kp_nspreads, kp_next;
	double kp_spread;
	mc_pose_prior *prior; /* NULL: none (mc_tracker_load_pose_prior) */
};

/* Calibration at the current pose on one frame set: with `colours`, each
 * Gaussian's colour (thesis 5.3.2); always the background colour, the
 * per-Gaussian evidence and the baseline energy; actor_version++ on
 * success. */
int mc_trk_calibrate(mc_tracker *t, const mc_frame_view *views, int nviews, bool colours, mc_err *err);

/* Converts the views to working-resolution RGB (t->rgb) and HSV (t->hsv);
 * returns how many cameras carry a usable, non-blank image (t->present). */
/* The settings' check (mc_tracker_settings.c): -1 with err naming the
 * setting out of range. */
int mc_trk_validate_settings(const mc_tracker_settings *s, mc_err *err);
/* A view with an image the tracker can read (mc_pixels.c). */
bool mc_trk_view_usable(const mc_frame_view *v);
int mc_trk_load_views(mc_tracker *t, const mc_frame_view *views, int nviews);
/* The Gaussians at a pose, as the image energy sees them. */
void mc_trk_make_scene(const mc_tracker *t, const mc_fk *fk, mc_scene *scene);
/* Candidate pixels (t->candidates) near the body at fk. */
void mc_trk_choose_candidates(mc_tracker *t, const mc_fk *fk);
/* Draws a share of each present camera's candidates into t->samples;
 * returns how many in all. */
int mc_trk_sample_pixels(mc_tracker *t, double fraction);
/* A share (fraction) of the pixels near the marked Gaussians (gauss[q])
 * at pose a or at pose b, in the present cameras, as the sample of the
 * next evaluation (the candidates are left alone); returns how many. */
int mc_trk_sample_near(mc_tracker *t, const mc_fk *a, const mc_fk *b, const bool *gauss, double fraction);
/* E_color over t->samples as a mean per sampled pixel, and its gradient
 * with respect to the Gaussian centres. */
int mc_trk_data_term(mc_tracker *t, const mc_scene *scene, int nsampled, double dropout, double *E, mc_vec3 *dmu,
		     mc_err *err);

/* The colour energy of the current views at a pose (a quarter of its
 * candidate pixels, no dropout), for comparing two poses. */
int mc_trk_pose_energy(mc_tracker *t, const double *pose, double *E, mc_err *err);

/* The valid working pixel of camera c that a rig-frame point projects to,
 * or -1. */
int mc_trk_working_pixel(const mc_tracker *t, int c, mc_vec3 p_rig);
/* Each visible Gaussian's image evidence at a pose: sum over the present
 * cameras of V_q (-d(I, a_q)) at the pixel of its centre; 0 for hidden
 * Gaussians. */
void mc_trk_gaussian_evidence(const mc_tracker *t, const double *pose, double *per_gauss);
/* Fills out->joints[j].confidence for a tracked pose (see docs/TRACKER.md,
 * "Per-joint confidence"); 0 for every joint when out->state is lost. */
void mc_trk_joint_confidence(const mc_tracker *t, const double *pose, mc_skeleton *out);

/* ---- the keypoint term (mc_keypoint_term.c) ---- */

#define MC_TRK_MAX_KEYPOINTS (2 * MC_MAX_JOINTS * MC_MAX_CAMERAS)

/* A detected keypoint as a ray in the rig frame. */
typedef struct {
	int joint;     /* model joint */
	mc_vec3 origin, dir;
	double weight; /* the detection's confidence, 0..1 */
} mc_trk_keypoint_ray;

/* Left/right pairs of a frame set's keypoint rays relabelled by the views'
 * agreement and the tracked pose (mc_sides.c; settings.assign_sides). */
void mc_trk_assign_sides(const mc_tracker *t, mc_trk_keypoint_ray *r, const int *cam, int n);
/* Fills t->other_side from the model, once, when the tracker is created. */
void mc_trk_find_other_sides(mc_tracker *t);
/* The joint on the other side of the body (left_x <-> right_x), or -1. */
int mc_trk_other_side(const mc_tracker *t, int joint);
/* Every left/right label of the rays exchanged (the body turned around). */
void mc_trk_exchange_sides(const mc_tracker *t, mc_trk_keypoint_ray *r, int n);

/* Fills t->unpulled from the model and t->fixed_joint, once, when the
 * tracker is created: the joints whose keypoints pull neither in the
 * keypoint term nor in the ray fit (they still count in the triangulation,
 * mc_init.c). */
void mc_trk_find_unpulled(mc_tracker *t);

/* The frame's keypoints as rays, once per frame, with each ray's camera
 * (cam): unusable ones left out, and those that disagree with more of the
 * other cameras' rays of their joint than agree given weight 0.  Returns
 * the count. */
int mc_trk_prepare_keypoints(const mc_tracker *t, const mc_keypoint *kp, int nkp, mc_trk_keypoint_ray *out, int *cam);

/* The keypoints of the frame set being tracked: those given, then those the
 * poll brings, and their rays (made again from all of them when more come,
 * so that the check across cameras sees every camera). */
typedef struct mc_trk_frame_keypoints {
	mc_keypoint given[MC_TRK_MAX_KEYPOINTS];
	int ngiven;
	mc_trk_keypoint_ray rays[MC_TRK_MAX_KEYPOINTS];
	int cam[MC_TRK_MAX_KEYPOINTS];
	int nrays;
} mc_trk_frame_keypoints;

/* The closest points *pa, *pb of two rays: 1, or 0 for parallel rays
 * (nothing set), -1 when they meet behind either origin. */
int mc_trk_ray_closest(const mc_trk_keypoint_ray *a, const mc_trk_keypoint_ray *b, mc_vec3 *pa, mc_vec3 *pb);

/* After a frame set: the cameras' agreement on its keypoints joins the
 * running spread, and the keypoint term's trust follows it. */
void mc_trk_update_trust(mc_tracker *t);

/* E_detection at a pose (0 when lambda_detection is 0); adds its pose
 * gradient to grad. */
double mc_trk_detection_term(mc_tracker *t, const double *pose, const mc_fk *fk, const mc_trk_keypoint_ray *kp, int n,
			     double *grad);

/* Before the iterations: pose (the prediction, in/out) fitted to the frame
 * set's keypoint rays where that helps (mc_ray_fit.c); -1 with err. */
int mc_trk_ray_fit(mc_tracker *t, const double *pred, double *pose, mc_err *err);

/* ---- starting and recovering from detections (mc_init.c) ---- */

/* The pose fitted to the triangulated joints' rays from the rest pose
 * placed on them, into pose; returns the RMS distance from the rays, or
 * -1.  The first fit and a re-fit of the whole body use
 * MC_TRK_FULL_FIT_ITERATIONS with restarts. */
#define MC_TRK_FULL_FIT_ITERATIONS 60
double mc_trk_fit_from_rest(const mc_tracker *t, const mc_trk_triangulation *tri, int iterations, bool restarts,
			    double *pose);

/* ---- which way the body faces (mc_facing.c) ---- */

/* The first pose (as mc_trk_fit_from_rest); on an outside-in rig whose
 * sides the tracker decides, also fitted with every left/right pair
 * exchanged, the better kept (*turned then true). */
double mc_trk_facing_fit(const mc_tracker *t, const mc_trk_triangulation *tri, double *pose, bool *turned);
/* The pose fitted with every left/right pair exchanged (the body turned
 * around): mc_trk_fit_from_rest's result. */
double mc_trk_facing_fit_turned(const mc_tracker *t, const mc_trk_triangulation *tri, double *pose);
/* One frame set's check while tracking: true when the recent frame sets'
 * rays say that the tracked body faces the wrong way. */
bool mc_trk_facing_wrong(mc_tracker *t, const mc_trk_triangulation *tri);
void mc_trk_facing_reset(mc_trk_facing *f);

/* Waits for a first pose from detections (the rest pose until then);
 * flags: MC_INIT_* (mc_tracker.h). */
int mc_trk_init_start(mc_tracker *t, unsigned flags, mc_err *err);
/* Before tracking a frame set: the first pose when waiting, a re-fit when
 * lost or stuck, the body turned around when it faces the wrong way (the
 * rays then relabelled), the shape samples.  Returns 1 while still
 * waiting, 0 to track, -1 with err. */
int mc_trk_init_step(mc_tracker *t, const mc_frame_view *views, int nviews, mc_trk_keypoint_ray *rays,
		     const int *cam, int nrays, mc_err *err);
/* After tracking: the state and confidence, for recovery, and the pose of
 * a collected frame set. */
void mc_trk_init_after(mc_tracker *t, const mc_skeleton *out);
void mc_trk_init_free(mc_tracker *t);

/* mc_widths.c: starts measuring the pairs' widths (measure: on a rig whose
 * root is fixed to the head, started from detections without an actor
 * file); adds a frame set's triangulated pairs; once MC_TRK_WIDTH_FRAMES
 * frame sets are seen, sets the widths and learns the colours again. */
void mc_trk_widths_start(mc_tracker *t, bool measure);
void mc_trk_widths_collect(mc_tracker *t, const mc_trk_triangulation *tri);
int mc_trk_widths_finish(mc_tracker *t, const mc_frame_view *views, int nviews, mc_err *err);

#endif
