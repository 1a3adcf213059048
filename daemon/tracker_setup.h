/* tracker_setup: the [tracker] section made real: the rig, the body model, the
 * tracker with its settings, its initial pose, and the map from configured
 * cameras to rig cameras.
 *
 * Initial pose: with `init_joints = gt.json`, frame 0's joints (rig frame,
 * i.e. the left camera frame of the ego data, read by core/eval/mc_gt.h)
 * initialise pose and bone lengths through mc_tracker_init_from_joints;
 * otherwise the model's rest pose.  Errors name the config key they come from, e.g.
 *   "mocapd.conf:24: [tracker] rig: rigs/x.json: cameras[0].f: ..." */
#ifndef MCD_TRACKER_SETUP_H
#define MCD_TRACKER_SETUP_H

#include "config.h"
#include "base/mc_error.h"
#include "body/mc_model.h"
#include "geom/mc_rig.h"
#include "track/mc_tracker.h"

typedef struct {
	mc_rig rig;
	mc_model model;
	mc_tracker *tracker;
	mc_tracker_settings settings;
	int cam_to_rig[MC_MAX_CAMERAS]; /* configured camera -> rig camera index */
	char *rig_json;                  /* the rig as JSON text, for clients; NULL if unknown */
	bool calibrate_pending;          /* calibrate colours on the first complete frame set */
} mcd_tracking;

/* Loads rig, model and initial joints and maps the cameras, without
 * creating a tracker (no OpenCL): what `mocapd --check` verifies. */
int mcd_tracking_check(const mcd_config *cfg, mc_err *err);

/* Loads rig and model, creates and initialises the tracker. */
int mcd_tracking_setup(const mcd_config *cfg, mcd_tracking *t, mc_err *err);
/* The tracker settings of a config for a rig of this kind: on an
 * outside-in rig, the keys the file leaves out take their outside-in
 * values (mc_tracker_outside_in). */
void mcd_tracker_settings(const mcd_config *cfg, const mc_rig *rig, mc_tracker_settings *s);
void mcd_tracking_free(mcd_tracking *t);

/* Applies the budget of reloaded settings (iterations, pixel_fraction,
 * dropout, step, momentum: the [tracker] keys the config table marks
 * reloadable) through mc_tracker_set_budget, keeping the actor, the pose
 * and the device.  Call on the tracking thread, between frames. */
int mcd_tracking_reload(mcd_tracking *t, const mc_tracker_settings *want, mc_err *err);

#endif
