/* Which way the body faces (outside-in rigs; docs/TRACKER.md, "Facing").
 *
 * A detector that has not seen a face takes a body seen from behind for
 * one facing the camera and exchanges every left/right pair in that view.
 * When most views do so, the sides (mc_sides.c) follow the majority, and
 * the labels exchanged in every view describe the same body turned around:
 * the shoulders, hips and limbs land on the same points.  What tells the
 * two apart is the body's build: knees bend forwards, elbows one way, the
 * head sits in front of the neck.  A body fitted to the rays facing the
 * wrong way misses them more.
 *
 * So the first pose is fitted both ways and the better kept; and while
 * tracking, every frame set with enough detections fits both labellings
 * again from the rest pose (short fits without restarts: 1.2 ms for the
 * two on the walk clip, one core) and keeps log(exchanged RMS / kept RMS).
 * When the mean of the last MC_TRK_FACING_CHECKS is below FACING_TURN_LOG,
 * the tracked body faces the wrong way (the sides, which then follow the
 * pose, keep it so): it is turned around.  Over the four outside-in
 * evaluation clips (two held out), such a window's mean stayed above -0.01
 * while the tracked body faced the right way (the whole clip's mean above
 * 0.25); facing the wrong way it fell under -0.12 within the first 10
 * checks (mean -0.16 to -0.25 over the clip). */
#include "base/mc_stats.h"
#include "track/mc_tracker_internal.h"

#include <math.h>
#include <string.h>

#define FACING_CHECK_ITERATIONS 15
/* log(0.89): the exchanged labels miss their rays by 11 % less, on average */
#define FACING_TURN_LOG (-0.12)

/* The triangulation with every left/right pair's labels exchanged. */
static void exchanged(const mc_tracker *t, const mc_trk_triangulation *in, mc_trk_triangulation *out)
{
	*out = *in;
	for (int j = 0; j < t->model.njoints; j++) {
		int k = mc_trk_other_side(t, j);
		if (k <= j) /* each pair once */
			continue;
		out->have[j] = in->have[k];
		out->have[k] = in->have[j];
		out->pos[j] = in->pos[k];
		out->pos[k] = in->pos[j];
		out->conf[j] = in->conf[k];
		out->conf[k] = in->conf[j];
		out->nray[j] = in->nray[k];
		out->nray[k] = in->nray[j];
		memcpy(out->ray[j], in->ray[k], sizeof(out->ray[j]));
		memcpy(out->ray[k], in->ray[j], sizeof(out->ray[k]));
	}
}

static bool facing_applies(const mc_tracker *t)
{
	return t->s.assign_sides && t->model.root_free;
}

double mc_trk_facing_fit_turned(const mc_tracker *t, const mc_trk_triangulation *tri, double *pose)
{
	mc_trk_triangulation other;
	exchanged(t, tri, &other);
	return mc_trk_fit_from_rest(t, &other, MC_TRK_FULL_FIT_ITERATIONS, true, pose);
}

double mc_trk_facing_fit(const mc_tracker *t, const mc_trk_triangulation *tri, double *pose, bool *turned)
{
	*turned = false;
	double rms = mc_trk_fit_from_rest(t, tri, MC_TRK_FULL_FIT_ITERATIONS, true, pose);
	if (!facing_applies(t))
		return rms;
	double other_pose[MC_MAX_DOF];
	double other_rms = mc_trk_facing_fit_turned(t, tri, other_pose);
	if (other_rms >= 0 && (rms < 0 || other_rms < rms)) {
		memcpy(pose, other_pose, sizeof(other_pose));
		*turned = true;
		return other_rms;
	}
	return rms;
}

void mc_trk_facing_reset(mc_trk_facing *f)
{
	memset(f, 0, sizeof(*f));
}

bool mc_trk_facing_wrong(mc_tracker *t, const mc_trk_triangulation *tri)
{
	mc_trk_facing *f = &t->init.facing;
	if (!facing_applies(t))
		return false;
	mc_trk_triangulation other;
	double pose[MC_MAX_DOF];
	exchanged(t, tri, &other);
	double kept = mc_trk_fit_from_rest(t, tri, FACING_CHECK_ITERATIONS, false, pose);
	double turned = mc_trk_fit_from_rest(t, &other, FACING_CHECK_ITERATIONS, false, pose);
	if (!(kept > 0 && turned > 0))
		return false;
	mc_stats_window_add(f->log_ratio, MC_TRK_FACING_CHECKS, &f->n, &f->next, log(turned / kept));
	if (f->n < MC_TRK_FACING_CHECKS)
		return false;
	double sum = 0;
	for (int i = 0; i < MC_TRK_FACING_CHECKS; i++)
		sum += f->log_ratio[i];
	return sum / MC_TRK_FACING_CHECKS < FACING_TURN_LOG;
}

void mc_trk_exchange_sides(const mc_tracker *t, mc_trk_keypoint_ray *r, int n)
{
	for (int i = 0; i < n; i++) {
		int k = mc_trk_other_side(t, r[i].joint);
		if (k >= 0)
			r[i].joint = k;
	}
}
