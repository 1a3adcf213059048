/* mocapd end to end with the tracker: the bundled clip (tests/data/ego_demo)
 * through the files driver, grouped, converted from JPEG, tracked on OpenCL
 * (PoCL) from the initial joints of frame 0, printed and saved; then a
 * looping clip whose tracker budget is changed by SIGHUP while it runs; and
 * an outside-in rig (tests/data/outside_demo) tracked in the world frame. */
#include "daemon/harness.h"
#include "body/mc_model.h"
#include "test_util.h"

#define CONF(extra_camera_keys, extra_tracker_keys)                  \
	"[daemon]\n"                                                  \
	"plugin_dir = @DRIVERS@\n"                                    \
	"[camera left]\n"                                             \
	"driver = files\n"                                            \
	"rig_camera = left\n"                                         \
	"path = @REPO@/tests/data/ego_demo/left\n" extra_camera_keys  \
	"[camera right]\n"                                            \
	"driver = files\n"                                            \
	"rig_camera = right\n"                                        \
	"path = @REPO@/tests/data/ego_demo/right\n" extra_camera_keys \
	"[tracker]\n"                                                 \
	"rig = @REPO@/config/rigs/ego_stereo.json\n"                  \
	"model = @REPO@/config/models/default.json\n"                 \
	"init_joints = @REPO@/tests/data/ego_demo/gt.json\n" extra_tracker_keys \
	"[socket]\n"                                                  \
	"path = @SOCK@\n"

static char repo[PATH_MAX];

/* mcd_run_config with @DRIVERS@ and @REPO@ filled in too. */
static void write_config(mcd_run *r, const char *tmpl)
{
	char text[8192] = "";
	const char *p = tmpl;
	while (*p) {
		if (strncmp(p, "@DRIVERS@", 9) == 0) {
			strcat(text, mcd_build_dir);
			strcat(text, "/drivers");
			p += 9;
		} else if (strncmp(p, "@REPO@", 6) == 0) {
			strcat(text, repo);
			p += 6;
		} else
			strncat(text, p++, 1);
	}
	mcd_run_config(r, text);
}

/* Skips the whole test when the tracker cannot run here (no OpenCL). */
static void skip_without_opencl(mcd_run *r)
{
	char *log = mcd_read_file(r->log);
	bool no_cl = log && (strstr(log, "OpenCL") || strstr(log, "CL_")) && strstr(log, "error");
	free(log);
	if (no_cl) {
		mcd_run_dump(r, "no OpenCL");
		mcd_run_cleanup(r);
		TEST_SKIP("the tracker cannot run here (no usable OpenCL device)");
	}
}

/* The value of joint `name` in a --print line: " name=(x,y,z)". */
static bool joint_in_line(const char *line, const char *name, mc_vec3 *v)
{
	char key[64];
	snprintf(key, sizeof(key), " %s=(", name);
	const char *at = strstr(line, key);
	return at && sscanf(at + strlen(key), "%lf,%lf,%lf", &v->x, &v->y, &v->z) == 3;
}

/* Runs mocapd (args: --print --exit-at-end ...) on the config in r to its
 * end (skipping the test without OpenCL) and returns its --print output;
 * *lines frame sets, *tracked of them tracked (at least 5 expected). */
static char *run_clip(mcd_run *r, const char *const *args, const char *all_cams, int *lines, int *tracked)
{
	CHECK(mcd_run_start(r, args, NULL));
	int rc = mcd_run_wait_exit(r, 120000);
	if (rc == 1)
		skip_without_opencl(r);
	CHECK_MSG(rc == 0, "exit %d", rc);
	char *out = mcd_read_file(r->out);
	*lines = mcd_count(out, "frame ");
	*tracked = *lines - mcd_count(out, "(not tracked)");
	printf("%d frame sets tracked, %d with every camera (%s)\n", *tracked, mcd_count(out, all_cams), all_cams);
	CHECK_MSG(*tracked >= 5, "%d frame sets tracked", *tracked);
	return out;
}

static void test_clip(void)
{
	mcd_run r;
	CHECK(mcd_run_init(&r));
	write_config(&r, CONF("", ""));
	char poses[128];
	snprintf(poses, sizeof(poses), "%s/poses", r.dir);
	mkdir(poses, 0755);
	const char *const args[] = {"--print", "--exit-at-end", "--save-poses", poses, NULL};
	int lines, tracked;
	char *out = run_clip(&r, args, "cams 2/2", &lines, &tracked);
	CHECK(r.notes && strstr(r.notes, "READY=1"));
	CHECK(mcd_run_wait_log(&r, "tracker: initialised from 18 joints", 0));
	int pairs = mcd_count(out, "cams 2/2");
	CHECK_MSG(pairs >= lines - 1, "%d of %d frame sets have both cameras", pairs, lines);
	/* The first frame set starts from frame 0's ground truth:
	 * neck (0.150, 0.267, 0.170) in the left camera frame. */
	mc_vec3 neck;
	CHECK(out && joint_in_line(out, "neck", &neck));
	CHECK_NEAR(neck.x, 0.150, 0.03);
	CHECK_NEAR(neck.y, 0.267, 0.03);
	CHECK_NEAR(neck.z, 0.170, 0.03);
	free(out);
	/* The saved actor and poses are what mocap-render reads. */
	char path[256];
	snprintf(path, sizeof(path), "%s/actor.json", poses);
	mc_model *actor = calloc(1, sizeof(*actor));
	mc_err err = {{0}};
	CHECK_MSG(actor && mc_model_load(path, actor, &err) == 0, "%s", err.msg);
	snprintf(path, sizeof(path), "%s/pose_00000.json", poses);
	char *pose = mcd_read_file(path);
	CHECK_MSG(pose && strstr(pose, "\"pose\": [") && strstr(pose, "frame 0"), "%s", path);
	const char *values = pose ? strstr(pose, "\"pose\": [") : NULL;
	int commas = values ? mcd_count(values, ", ") : 0;
	CHECK_MSG(actor && commas == actor->ndof - 1, "%d values for %d dofs", commas + 1, actor ? actor->ndof : 0);
	free(pose);
	free(actor);
	char cmd[300];
	snprintf(cmd, sizeof(cmd), "rm -rf %s", poses);
	CHECK(system(cmd) == 0);
	if (mc_test_failures)
		mcd_run_dump(&r, "clip");
	mcd_run_cleanup(&r);
}

/* An outside-in rig from the clip's own cameras.json (rig_format =
 * cameras-json), four files cameras (tests/data/outside_demo): the tracker
 * takes the outside-in settings, starts from joints_world and prints
 * skeletons in the world frame (z up): the first one at frame 0's neck
 * (-0.247, 1.399, 1.747). */
static void test_outside_in(void)
{
	char conf[8192] = "[daemon]\nplugin_dir = @DRIVERS@\n";
	for (int c = 0; c < 4; c++)
		snprintf(conf + strlen(conf), sizeof(conf) - strlen(conf),
			 "[camera cam%d]\ndriver = files\nrig_camera = cam%d\npath = @REPO@/tests/data/outside_demo/cam%d\n", c,
			 c, c);
	snprintf(conf + strlen(conf), sizeof(conf) - strlen(conf),
		 "[tracker]\nrig = @REPO@/tests/data/outside_demo/cameras.json\nrig_format = cameras-json\n"
		 "model = @REPO@/config/models/default.json\ninit_joints = @REPO@/tests/data/outside_demo/gt.json\n"
		 "[socket]\npath = @SOCK@\n");
	mcd_run r;
	CHECK(mcd_run_init(&r));
	write_config(&r, conf);
	const char *const args[] = {"--print", "--exit-at-end", NULL};
	int lines, tracked;
	char *out = run_clip(&r, args, "cams 4/4", &lines, &tracked);
	CHECK(mcd_run_wait_log(&r, "tracker: outside-in rig: iterations 80, lambda_smooth 0.01, lambda_floor 0, lambda_detection 0.3, "
				    "pixel_fraction 0.14", 0));
	CHECK(mcd_run_wait_log(&r, "rig outside_in (4 cameras)", 0));
	mc_vec3 neck;
	CHECK(out && joint_in_line(out, "neck", &neck));
	CHECK_NEAR(neck.x, -0.247, 0.03);
	CHECK_NEAR(neck.y, 1.399, 0.03);
	CHECK_NEAR(neck.z, 1.747, 0.03);
	free(out);
	if (mc_test_failures)
		mcd_run_dump(&r, "outside-in");
	mcd_run_cleanup(&r);
}

/* --check loads rig, model, pose prior and initial joints and maps the
 * cameras. */
static void test_check(void)
{
	mcd_run r;
	CHECK(mcd_run_init(&r));
	const char *const check[] = {"--check", NULL};
	write_config(&r, CONF("", "pose_prior = @REPO@/config/models/pose_prior.json\n"));
	CHECK(mcd_run_start(&r, check, NULL));
	CHECK(mcd_run_wait_exit(&r, 20000) == 0);
	/* a pose prior for another model: a dof this one lacks */
	char prior[160], tracker_keys[256];
	snprintf(prior, sizeof(prior), "%s/prior.json", r.dir);
	FILE *f = fopen(prior, "w");
	CHECK(f != NULL);
	if (f) {
		fputs("{\"dofs\": [\"left_knee.z\"], \"components\": [{\"weight\": 1, \"mean\": [0], "
		      "\"precision_chol\": [[1]]}]}\n",
		      f);
		fclose(f);
	}
	snprintf(tracker_keys, sizeof(tracker_keys), "pose_prior = %s\n", prior);
	char conf[8192];
	snprintf(conf, sizeof(conf), CONF("", "%s"), tracker_keys);
	write_config(&r, conf);
	CHECK(mcd_run_start(&r, check, NULL));
	CHECK(mcd_run_wait_exit(&r, 20000) == 1);
	CHECK(mcd_run_wait_log(&r, "[tracker] pose_prior: ", 0));
	CHECK(mcd_run_wait_log(&r, "dofs[0]: the model has no dof 'left_knee.z'", 0));
	/* a rig camera the rig does not have */
	write_config(&r, "[daemon]\nplugin_dir = @DRIVERS@\n[camera left]\ndriver = files\nrig_camera = middle\n"
			 "path = @REPO@/tests/data/ego_demo/left\n[tracker]\nrig = @REPO@/config/rigs/ego_stereo.json\n"
			 "model = @REPO@/config/models/default.json\n");
	CHECK(mcd_run_start(&r, check, NULL));
	CHECK(mcd_run_wait_exit(&r, 20000) == 1);
	CHECK(mcd_run_wait_log(&r, ":5: [camera left] rig_camera: 'middle' is not a camera of rig", 0));
	CHECK(mcd_run_wait_log(&r, "(it has: left, right)", 0));
	/* a model file that is not there */
	write_config(&r, "[daemon]\nplugin_dir = @DRIVERS@\n[camera left]\ndriver = files\nrig_camera = left\n"
			 "path = @REPO@/tests/data/ego_demo/left\n[tracker]\nrig = @REPO@/config/rigs/ego_stereo.json\n"
			 "model = @REPO@/config/models/nosuch.json\n");
	CHECK(mcd_run_start(&r, check, NULL));
	CHECK(mcd_run_wait_exit(&r, 20000) == 1);
	CHECK(mcd_run_wait_log(&r, ":9: [tracker] model: ", 0));
	CHECK(mcd_run_wait_log(&r, "nosuch.json", 0));
	if (mc_test_failures)
		mcd_run_dump(&r, "check");
	mcd_run_cleanup(&r);
}

static void test_reload_budget(void)
{
	mcd_run r;
	CHECK(mcd_run_init(&r));
	write_config(&r, CONF("loop = true\n", "iterations = 30\n"));
	const char *const args[] = {"--print", NULL};
	CHECK(mcd_run_start(&r, args, NULL));
	CHECK(mcd_run_wait_notify(&r, "READY=1", 60000));
	CHECK(mcd_run_wait_log(&r, "30 iterations", 0));
	CHECK(mcd_run_wait_notify(&r, "tracking", 5000));
	write_config(&r, CONF("loop = true\n", "iterations = 10\npixel_fraction = 0.1\n"));
	mcd_run_signal(&r, SIGHUP);
	CHECK(mcd_run_wait_log(&r, "tracker: now 10 iterations, pixel fraction 0.1", 60000));
	int before = mcd_run_count(r.out, "frame ");
	mcd_sleep_ms(1000);
	CHECK_MSG(mcd_run_count(r.out, "frame ") > before, "no frame set tracked after the reload");
	CHECK(mcd_run_alive(&r));
	mcd_run_stop(&r, 20000, "reload");
}

int main(void)
{
	mcd_require_files_driver(repo, sizeof(repo));
	test_check();
	test_clip();
	test_outside_in();
	test_reload_budget();
	return mc_test_finish("test_daemon_track");
}
