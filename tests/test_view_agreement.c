/* mc_view_agreement (core/eval): keypoints of a point seen by the four
 * cameras of real footage's rig (tests/data/real_p2s/cameras.json) agree;
 * one moved 60 px (at 640) does not; a joint seen by three cameras is not
 * checked; keypoints below the confidence floor are left out. */
#include "eval/mc_view_agreement.h"
#include "test_util.h"

static int project_all(const mc_rig *rig, mc_vec3 world, int joint, mc_keypoint *kp)
{
	int n = 0;
	for (int c = 0; c < rig->ncams; c++) {
		const mc_camera *cam = &rig->cams[c];
		double u, v;
		if (mc_camera_project_rig(cam, world, &u, &v))
			kp[n++] = (mc_keypoint){.cam = c, .joint = joint, .u = (float)u, .v = (float)v, .conf = 0.9f};
	}
	return n;
}

int main(void)
{
	mc_rig rig;
	mc_err err = {{0}};
	int rc = mc_rig_import_cameras_json("tests/data/real_p2s/cameras.json", &rig, &err);
	CHECK_MSG(rc == 0, "%s", err.msg);
	if (rc != 0)
		return mc_test_finish("test_view_agreement");
	CHECK(rig.ncams == 4);
	mc_keypoint kp[8];
	int n = project_all(&rig, mc_v3(0.0, 0.0, 1.0), 3, kp);
	CHECK(n == 4);

	mc_view_agreement a = {0, 0};
	mc_view_agreement_add(&a, &rig, kp, n, 0.3, 15.0);
	CHECK(a.checked == 4 && a.agreed == 4);

	/* cam0's keypoint 60 px off (its image is 640 high): it disagrees. */
	mc_view_agreement one = {0, 0};
	kp[0].u += 60;
	mc_view_agreement_add(&one, &rig, kp, 1, 0.3, 15.0); /* alone: nothing to check against */
	CHECK(one.checked == 0);
	mc_view_agreement b = {0, 0};
	mc_view_agreement_add(&b, &rig, kp, n, 0.3, 15.0);
	CHECK(b.checked == 4 && b.agreed <= 3);
	mc_view_agreement exact_others = {0, 0};
	mc_keypoint others_only[4] = {kp[1], kp[2], kp[3], kp[0]};
	others_only[3].conf = 0.1f; /* below the floor: left out, and then no one has three others */
	mc_view_agreement_add(&exact_others, &rig, others_only, 4, 0.3, 15.0);
	CHECK(exact_others.checked == 0);

	/* Three cameras: not checked. */
	mc_view_agreement c3 = {0, 0};
	mc_view_agreement_add(&c3, &rig, kp + 1, 3, 0.3, 15.0);
	CHECK(c3.checked == 0);

	/* Two joints do not mix. */
	mc_keypoint two[8];
	int m = project_all(&rig, mc_v3(0.0, 0.0, 1.0), 1, two);
	m += project_all(&rig, mc_v3(0.2, 0.1, 0.5), 2, two + m);
	mc_view_agreement d = {0, 0};
	mc_view_agreement_add(&d, &rig, two, m, 0.3, 15.0);
	CHECK(d.checked == 8 && d.agreed == 8);
	return mc_test_finish("test_view_agreement");
}
