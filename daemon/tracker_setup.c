#include "tracker_setup.h"

#include "frame_size.h"

#include "log.h"
#include "body/mc_pose_prior.h"
#include "eval/mc_gt.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int load_rig(const mcd_config *cfg, mcd_tracking *t, mc_err *err)
{
	const mcd_tracker_config *tc = &cfg->tracker;
	char where[700];
	mcd_config_where(cfg, "tracker", "rig", where, sizeof(where));
	int rc;
	switch (tc->rig_format) {
	case MCD_RIG_EGO_CALIB: rc = mc_rig_import_ego_calib(tc->rig, tc->rig_ocam, &t->rig, err); break;
	case MCD_RIG_CAMERAS_JSON: rc = mc_rig_import_cameras_json(tc->rig, &t->rig, err); break;
	default: rc = mc_rig_load(tc->rig, &t->rig, err); break;
	}
	if (rc)
		return mc_err_prefix(err, "%s", where);
	/* Clients get the rig in the rig file format, whatever it came from. */
	mc_err ignored;
	t->rig_json = mc_rig_to_json(&t->rig, &ignored);
	return 0;
}

static int map_cameras(const mcd_config *cfg, mcd_tracking *t, mc_err *err)
{
	for (int i = 0; i < cfg->ncams; i++) {
		const mcd_camera_config *c = &cfg->cams[i];
		int idx = mc_rig_find(&t->rig, c->rig_camera);
		if (idx < 0) {
			char list[512] = "";
			for (int k = 0; k < t->rig.ncams; k++)
				snprintf(list + strlen(list), sizeof(list) - strlen(list), "%s%s", k ? ", " : "",
					 t->rig.cams[k].name);
			return mc_err_set(err, "%s:%d: [camera %s] rig_camera: '%s' is not a camera of rig %s (it has: %s)",
					  cfg->file, c->rig_camera_line, c->name, c->rig_camera, cfg->tracker.rig, list);
		}
		t->cam_to_rig[i] = idx;
	}
	return 0;
}

/* The joints of a gt.json-style file in the rig frame: the left camera's
 * on a head-mounted rig, the world's on an outside-in one. */
static const char *init_joints_key(const mc_rig *rig)
{
	return rig->kind == MC_RIG_OUTSIDE_IN ? "joints_world" : "joints_left_cam";
}

/* The pose and bone lengths from frame 0 of the init_joints file. */
static int init_from_joints(const mcd_config *cfg, mcd_tracking *t, mc_err *err)
{
	const char *path = cfg->tracker.init_joints;
	mc_gt gt;
	if (mc_gt_load(path, init_joints_key(&t->rig), &gt, err))
		return -1;
	const char *names[MC_GT_MAX_JOINTS];
	mc_vec3 pos[MC_GT_MAX_JOINTS];
	for (int j = 0; j < gt.njoints; j++) {
		names[j] = gt.joint_names[j];
		pos[j] = mc_gt_at(&gt, 0, j);
	}
	int n = gt.njoints;
	int rc = mc_tracker_init_from_joints(t->tracker, names, pos, n, err);
	mc_gt_free(&gt);
	if (rc == 0)
		mcd_info("tracker: initialised from %d joints of %s, frame 0", n, path);
	return rc;
}

static int init_pose(const mcd_config *cfg, mcd_tracking *t, mc_err *err)
{
	if (!cfg->tracker.init_joints[0]) {
		/* No ground truth: the first pose, the colours and (outside-in)
		 * the actor's size come from the detections; until then the
		 * state is "initialising". */
		bool actor = cfg->tracker.actor[0];
		if (mc_tracker_start_from_detections(t->tracker, actor ? MC_INIT_KEEP_ACTOR : MC_INIT_MEASURE_SIZE, err) < 0)
			return -1;
		t->calibrate_pending = false;
		if (actor)
			mcd_info("tracker: actor %s (its size and colours); waiting for detections (state initialising)",
				 cfg->tracker.actor);
		else
			mcd_info("tracker: no init_joints: waiting for detections of the actor (state initialising)");
		return 0;
	}
	char where[700];
	if (init_from_joints(cfg, t, err))
		return mc_err_prefix(err, "%s", mcd_config_where(cfg, "tracker", "init_joints", where, sizeof(where)));
	return 0;
}

/* An actor file is a model file saved by `mocapctl actor save` (the
 * model with the actor's bone scales, head placement and colours): it
 * must have the configured model's skeleton and Gaussians. */
static int check_actor_fits(const mc_model *model, const mc_model *actor, mc_err *err)
{
	if (actor->njoints != model->njoints || actor->ngauss != model->ngauss || actor->root_free != model->root_free)
		return mc_err_set(err, "made for another model (%d joints, %d Gaussians, %s root; the model has %d, %d, %s)",
				  actor->njoints, actor->ngauss, actor->root_free ? "free" : "fixed", model->njoints,
				  model->ngauss, model->root_free ? "free" : "fixed");
	for (int j = 0; j < model->njoints; j++)
		if (strcmp(actor->joints[j].name, model->joints[j].name) ||
		    actor->joints[j].parent != model->joints[j].parent)
			return mc_err_set(err, "made for another model (joint %d is '%s', the model's is '%s')", j,
					  actor->joints[j].name, model->joints[j].name);
	return 0;
}

static int load_actor(const mcd_config *cfg, mcd_tracking *t, mc_err *err)
{
	mc_model *actor = malloc(sizeof(*actor));
	if (!actor)
		return mc_err_set(err, "out of memory");
	int rc = mc_model_load(cfg->tracker.actor, actor, err);
	if (rc == 0)
		rc = check_actor_fits(&t->model, actor, err);
	if (rc == 0)
		t->model = *actor;
	free(actor);
	if (rc) {
		char where[700];
		return mc_err_prefix(err, "%s: %s", mcd_config_where(cfg, "tracker", "actor", where, sizeof(where)),
				     cfg->tracker.actor);
	}
	return 0;
}

/* The rig, the camera map and the model (or the actor): what both --check
 * and the start need. */
static int load_rig_and_model(const mcd_config *cfg, mcd_tracking *t, mc_err *err)
{
	char where[700];
	if (load_rig(cfg, t, err) || map_cameras(cfg, t, err) || mcd_frame_size_check(cfg, &t->rig, t->cam_to_rig, err))
		return -1;
	if (mc_model_load(cfg->tracker.model, &t->model, err))
		return mc_err_prefix(err, "%s", mcd_config_where(cfg, "tracker", "model", where, sizeof(where)));
	/* as the tracker will (mc_tracker_create), so that an actor saved
	 * outside-in fits the configured model */
	if (t->rig.kind == MC_RIG_OUTSIDE_IN && mc_model_make_root_free(&t->model, err))
		return mc_err_prefix(err, "%s", mcd_config_where(cfg, "tracker", "model", where, sizeof(where)));
	if (cfg->tracker.actor[0] && load_actor(cfg, t, err))
		return -1;
	return 0;
}

/* The pose prior, loaded for the tracker's model: into the tracker when
 * there is one, else only checked (--check). */
static int load_pose_prior(const mcd_config *cfg, mcd_tracking *t, mc_err *err)
{
	char where[700];
	const char *path = cfg->tracker.pose_prior;
	if (!path[0])
		return 0;
	int rc;
	if (t->tracker) {
		rc = mc_tracker_load_pose_prior(t->tracker, path, err);
	} else {
		mc_pose_prior *p = mc_pose_prior_load(path, &t->model, err);
		rc = p ? 0 : -1;
		mc_pose_prior_free(p);
	}
	if (rc)
		return mc_err_prefix(err, "%s", mcd_config_where(cfg, "tracker", "pose_prior", where, sizeof(where)));
	return 0;
}

int mcd_tracking_check(const mcd_config *cfg, mc_err *err)
{
	mcd_tracking *t = calloc(1, sizeof(*t));
	if (!t)
		return mc_err_set(err, "out of memory");
	char where[700];
	int rc = load_rig_and_model(cfg, t, err);
	if (rc == 0)
		rc = load_pose_prior(cfg, t, err);
	if (rc == 0 && cfg->tracker.init_joints[0]) {
		mc_gt gt;
		rc = mc_gt_load(cfg->tracker.init_joints, init_joints_key(&t->rig), &gt, err);
		if (rc)
			mc_err_prefix(err, "%s", mcd_config_where(cfg, "tracker", "init_joints", where, sizeof(where)));
		else
			mc_gt_free(&gt);
	}
	mcd_tracking_free(t);
	free(t);
	return rc;
}

void mcd_tracker_settings(const mcd_config *cfg, const mc_rig *rig, mc_tracker_settings *s)
{
	static const struct {
		const char *key;
		unsigned flag;
	} keys[] = {{"iterations", MC_GIVEN_ITERATIONS},
		    {"lambda_smooth", MC_GIVEN_LAMBDA_SMOOTH},
		    {"lambda_floor", MC_GIVEN_LAMBDA_FLOOR},
		    {"lambda_detection", MC_GIVEN_LAMBDA_DETECTION},
		    {"lambda_prior", MC_GIVEN_LAMBDA_PRIOR},
		    {"ray_fit", MC_GIVEN_RAY_FIT},
		    {"detection_trust_max", MC_GIVEN_DETECTION_TRUST},
		    {"pixel_fraction", MC_GIVEN_PIXEL_FRACTION},
		    {"color_sight_cut", MC_GIVEN_COLOR_SIGHT_CUT}};
	*s = cfg->tracker.settings;
	if (rig->kind != MC_RIG_OUTSIDE_IN)
		return;
	unsigned given = 0;
	for (size_t i = 0; i < sizeof(keys) / sizeof(keys[0]); i++)
		if (mcd_config_is_set(cfg, "tracker", keys[i].key))
			given |= keys[i].flag;
	mc_tracker_settings_outside_in(s, rig->ncams, given);
}

int mcd_tracking_setup(const mcd_config *cfg, mcd_tracking *t, mc_err *err)
{
	memset(t, 0, sizeof(*t));
	if (load_rig_and_model(cfg, t, err))
		goto fail;
	mcd_tracker_settings(cfg, &t->rig, &t->settings);
	if (t->rig.kind == MC_RIG_OUTSIDE_IN)
		mcd_info("tracker: outside-in rig: iterations %d, lambda_smooth %g, lambda_floor %g, lambda_detection %g, "
			 "pixel_fraction %g",
			 t->settings.iterations, t->settings.lambda_smooth, t->settings.lambda_floor,
			 t->settings.lambda_detection, t->settings.pixel_fraction);
	t->tracker = mc_tracker_create(&t->rig, &t->model, &t->settings, err);
	if (!t->tracker) {
		mc_err_prefix(err, "%s:%d: [tracker]", cfg->file, cfg->tracker.line);
		goto fail;
	}
	if (load_pose_prior(cfg, t, err))
		goto fail;
	t->calibrate_pending = cfg->tracker.calibrate_colors;
	if (init_pose(cfg, t, err))
		goto fail;
	mcd_info("tracker: rig %s (%d cameras), model %s (%d joints, %d Gaussians), %dx%d, %d iterations, on %s",
		 t->rig.name, t->rig.ncams, t->model.name, t->model.njoints, t->model.ngauss, t->settings.width,
		 t->settings.height, t->settings.iterations, mc_tracker_device_name(t->tracker));
	return 0;
fail:
	mcd_tracking_free(t);
	return -1;
}

int mcd_tracking_reload(mcd_tracking *t, const mc_tracker_settings *want, mc_err *err)
{
	mc_tracker_settings s = t->settings;
	s.iterations = want->iterations;
	s.pixel_fraction = want->pixel_fraction;
	s.dropout = want->dropout;
	s.step = want->step;
	s.momentum = want->momentum;
	if (memcmp(&s, &t->settings, sizeof(s)) == 0)
		return 0;
	if (mc_tracker_set_budget(t->tracker, s.iterations, s.pixel_fraction, s.dropout, s.step, s.momentum, err) < 0)
		return -1;
	t->settings = s;
	mcd_info("tracker: now %d iterations, pixel fraction %g, dropout %g", s.iterations, s.pixel_fraction, s.dropout);
	return 0;
}

void mcd_tracking_free(mcd_tracking *t)
{
	if (t->tracker)
		mc_tracker_destroy(t->tracker);
	free(t->rig_json);
	t->tracker = NULL;
	t->rig_json = NULL;
}
