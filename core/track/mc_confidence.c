/* Per-joint confidence of the tracker (docs/TRACKER.md, "Per-joint
 * confidence").
 *
 * A joint's position is set by the bones on either side of it: the
 * Gaussians attached to the joint and to its parent.  Each Gaussian is
 * probed at the pixel of its centre in every camera: V_q (-d(I, a_q)) there
 * is about 1 when it is in view and the image has its colour, about 0 when
 * it is hidden, and negative when it lies on a different colour.  A joint's
 * evidence is the sum over its bones' probes; its confidence is that
 * evidence as a share of the same sum at calibration, clamped to [0, 1].
 * Probing every Gaussian, rather than a sample of the image, gives the
 * hands and feet (a few pixels each) as many probes as the torso. */
#include "track/mc_tracker_internal.h"

#include <string.h>

/* Evidence below which a joint counts as unseen at calibration; it
 * is then measured against this amount instead (about one probe of one of
 * its Gaussians matched in full). */
#define EVIDENCE_MIN 1.0

/* Evidence of Gaussian q: sum over the present cameras of V_q (-d(I, a_q))
 * at the pixel of its centre. */
static double probe_gaussian(const mc_tracker *t, const mc_scene *scene, int q)
{
	double e = 0;
	for (int c = 0; c < t->rig.ncams; c++) {
		int p = t->present[c] ? mc_trk_working_pixel(t, c, scene->mu[q]) : -1;
		if (p < 0)
			continue;
		const float *px = &t->hsv[c][3 * p];
		double i_hsv[3] = {px[0], px[1], px[2]};
		double v = mc_ray_visibility_of(scene, t->rays[c].origin, t->rays[c].dir[p], q);
		e -= v * mc_hsv_dissimilarity(scene->hsv[q], i_hsv);
	}
	return e;
}

void mc_trk_gaussian_evidence(const mc_tracker *t, const double *pose, double *per_gauss)
{
	mc_fk fk;
	mc_scene scene;
	mc_model_fk(&t->model, pose, &fk);
	mc_trk_make_scene(t, &fk, &scene);
	for (int q = 0; q < t->model.ngauss; q++)
		per_gauss[q] = t->hidden[q] ? 0 : probe_gaussian(t, &scene, q);
}

/* Per joint: the sum over the Gaussians attached to it and to its parent. */
static void joint_sums(const mc_tracker *t, const double *per_gauss, double *per_joint)
{
	memset(per_joint, 0, sizeof(double) * t->model.njoints);
	for (int q = 0; q < t->model.ngauss; q++) {
		int j = t->model.gauss[q].joint;
		per_joint[j] += per_gauss[q];
		/* the joint's children are placed by this bone too */
		for (int k = 0; k < t->model.njoints; k++)
			if (t->model.joints[k].parent == j)
				per_joint[k] += per_gauss[q];
	}
}

void mc_trk_joint_confidence(const mc_tracker *t, const double *pose, mc_skeleton *out)
{
	double per_gauss[MC_MAX_GAUSSIANS], evidence[MC_MAX_JOINTS], reference[MC_MAX_JOINTS];
	bool lost = out->state == MC_TRACK_LOST;
	if (!lost) {
		mc_trk_gaussian_evidence(t, pose, per_gauss);
		joint_sums(t, per_gauss, evidence);
		joint_sums(t, t->evidence0, reference);
	}
	for (int j = 0; j < t->model.njoints; j++) {
		double c;
		if (lost)
			c = 0;
		else if (t->fixed_joint[j])
			c = 1; /* rigid with the rig: known without an image */
		else
			c = evidence[j] / fmax(reference[j], EVIDENCE_MIN);
		out->joints[j].confidence = (float)fmin(fmax(c, 0.0), 1.0);
	}
}
