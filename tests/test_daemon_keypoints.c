/* Keypoints end to end: a client sends 2D keypoints for the right wrist
 * through the socket (libmocap), mocapd hands them to the tracker with the
 * frame set they belong to, and the published right wrist moves onto the
 * keypoint's ray.  The bundled clip plays in a loop through the files
 * driver at 5 fps, both cameras with one epoch, so that the client knows
 * the capture time of the next frame set. */
#include "daemon/harness.h"
#include "daemon/rays.h"
#include "test_util.h"


#define RATE 5
#define PERIOD_NS (1000000000ull / RATE)

static char repo[PATH_MAX];

static void write_config(mcd_run *r, uint64_t epoch)
{
	char text[8 * PATH_MAX], epoch_key[64];
	snprintf(epoch_key, sizeof(epoch_key), "epoch = %llu\n", (unsigned long long)epoch);
	mcd_demo_clip_config(text, sizeof(text), repo, RATE, "", epoch_key, NULL, "");
	mcd_run_config(r, text);
}

static void run(mcd_run *r, const mc_rig *rig)
{
	mocap_client *c = mocap_connect(r->sock, "test_daemon_keypoints");
	CHECK_MSG(c, "connect: %s", mocap_errmsg());
	if (!c)
		return;
	mocap_skeleton_def *def = calloc(1, sizeof(*def));
	mocap_skeleton_frame *f = calloc(1, sizeof(*f));
	int wrist = mcd_first_frame_joint(c, MOCAP_ALL, def, f, "right_wrist");
	if (!def || !f || wrist < 0 || mc_test_failures)
		goto out;

	/* A target 0.2 m from the wrist, across the left camera's line of sight,
	 * seen by both cameras. */
	mc_vec3 w0 = mcd_joint_position(f, wrist);
	mc_vec3 sight = mc_v3_normalize(mc_v3_sub(w0, rig->cams[0].rig_from_cam.t));
	mc_vec3 across = mc_v3_normalize(mc_v3_cross(sight, mc_v3(0, 0, 1)));
	mc_vec3 target = mc_v3_axpy(0.2, across, w0);
	mocap_keypoint kp[2];
	double u[2], v[2];
	for (int cam = 0; cam < 2; cam++) {
		CHECK(mc_camera_project_rig(&rig->cams[cam], target, &u[cam], &v[cam]));
		kp[cam] = (mocap_keypoint){wrist, (float)u[cam], (float)v[cam], 1.0f};
	}
	double before = mcd_ray_distance(&rig->cams[0], u[0], v[0], w0);

	/* Keypoints for the next frame set, after every frame received. */
	int sent = 0;
	for (int k = 0; k < 20; k++) {
		for (int cam = 0; cam < 2; cam++)
			if (mocap_send_keypoints(c, f->capture_ns + PERIOD_NS, cam, &kp[cam], 1) == 0)
				sent++;
		if (mocap_read_frame(c, f, 10000) != 1)
			break;
	}
	double after = mcd_ray_distance(&rig->cams[0], u[0], v[0], mcd_joint_position(f, wrist));
	double right = mcd_ray_distance(&rig->cams[1], u[1], v[1], mcd_joint_position(f, wrist));
	printf("right wrist from the keypoint ray: %.1f cm before, %.1f cm (left) and %.1f cm (right) after, "
	       "%d batches sent\n",
	       100 * before, 100 * after, 100 * right, sent);
	CHECK(sent == 40);
	CHECK_MSG(before > 0.15, "the target is only %.1f cm off the wrist", 100 * before);
	CHECK_MSG(after < 0.05 && right < 0.05, "the wrist stayed %.1f / %.1f cm off the keypoint rays", 100 * after,
		  100 * right);
out:
	free(def);
	free(f);
	mocap_close(c);
}

int main(void)
{
	mcd_require_build_and_clip(repo, sizeof(repo));
	mc_rig rig;
	if (!mcd_load_ego_rig(&rig))
		return 1;
	mcd_run r;
	CHECK(mcd_run_init(&r));
	write_config(&r, mc_now_ns() + 3000000000ull);
	const char *const args[] = {NULL};
	if (!mcd_run_start_ready(&r, args))
		return mc_test_finish("test_daemon_keypoints");
	run(&r, &rig);
	mcd_run_stop(&r, 20000, "keypoints");
	return mc_test_finish("test_daemon_keypoints");
}
