#include "bench/keypoints_out.h"

/* Printed to 1e-4 px and 1e-4 in confidence: finer than any detector's
 * sub-pixel output, so the file holds what the tracker got. */
static void write_view(FILE *f, int cam, const mc_rig *rig, const mc_model *m, const mc_keypoint *kp, int nkp)
{
	fprintf(f, "{\"camera\": \"%s\", \"joints\": {", rig->cams[cam].name);
	int n = 0;
	for (int i = 0; i < nkp; i++) {
		if (kp[i].cam != cam || kp[i].joint < 0 || kp[i].joint >= m->njoints)
			continue;
		fprintf(f, "%s\"%s\": [%.4f, %.4f, %.4f]", n++ ? ", " : "", m->joints[kp[i].joint].name, kp[i].u,
			kp[i].v, kp[i].conf);
	}
	fprintf(f, "}}");
}

void bench_keypoints_write(FILE *f, int k, const mc_rig *rig, const mc_model *m, const mc_keypoint *kp, int nkp)
{
	fprintf(f, "{\"index\": %d, \"views\": [", k);
	for (int c = 0; c < rig->ncams; c++) {
		if (c)
			fprintf(f, ", ");
		write_view(f, c, rig, m, kp, nkp);
	}
	fprintf(f, "]}\n");
}
