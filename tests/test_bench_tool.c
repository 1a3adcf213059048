/* Runs tools/mocap-bench (built next to this test, in BUILD/bin) on the
 * bundled clip (tests/data/ego_demo): the RESULT line's format, the --out
 * estimates scored here independently against the clip's gt.json (they must
 * give the MPJPE the tool printed), the simulated-detector warning, bad
 * command lines, the outside-in layout (tests/data/outside_demo), and the
 * detector run beside the tracker or before it (same estimates), the
 * JITTER line, --keypoints-out, and a clip without gt.json. */
#include "eval/mc_clip.h"
#include "test_util.h"

#include <jansson.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define FRAMES 12

static char tool[4096], tmpdir[64];

/* docs/CONVENTIONS.md's evaluated joints, as mocap-bench scores them. */
static const char *const evaluated[] = {
	"neck",      "left_shoulder", "left_elbow",     "left_wrist",  "left_hip",    "left_knee",
	"left_ankle", "left_toe",     "right_shoulder", "right_elbow", "right_wrist", "right_hip",
	"right_knee", "right_ankle",  "right_toe",
};
#define NEVAL ((int)(sizeof(evaluated) / sizeof(evaluated[0])))
/* The joints the simulated detector gives on a head rig: the runtime's */
#define SIM_HEAD_JOINTS 18

/* Runs the tool with `args`; returns its exit status and its output
 * (stdout and stderr) in out. */
static int run_tool(const char *args, char *out, size_t cap)
{
	char cmd[8192];
	snprintf(cmd, sizeof(cmd), "%s %s 2>&1", tool, args);
	return mc_test_run(cmd, out, cap);
}

/* The output's last line that starts with `prefix`, without its newline
 * (in a buffer of its own, valid until the next call); "" when none. */
static const char *line_of(const char *out, const char *prefix)
{
	static char line[1024];
	const char *found = NULL;
	for (const char *p = out; p && *p; p = strchr(p, '\n') ? strchr(p, '\n') + 1 : NULL)
		if (!strncmp(p, prefix, strlen(prefix)))
			found = p;
	line[0] = 0;
	if (found)
		snprintf(line, sizeof(line), "%.*s", (int)strcspn(found, "\n"), found);
	return line;
}

/* The jitter of the --out estimates, computed here from the file on its
 * own: finite differences at the clip's fps over consecutive lines. */
typedef struct {
	mc_vec3 est[2][NEVAL], gt[2][NEVAL];
	int run;
	double vel_sum, acc_est, acc_gt;
	int vel_n;
} jitter_check;

static void jitter_check_add(jitter_check *jc, const mc_vec3 *est, const mc_vec3 *gt, double fps)
{
	for (int e = 0; e < NEVAL; e++) {
		mc_vec3 e0 = jc->est[0][e], e1 = jc->est[1][e], g0 = jc->gt[0][e], g1 = jc->gt[1][e];
		if (jc->run >= 1) {
			mc_vec3 dv = mc_v3_sub(mc_v3_sub(est[e], e0), mc_v3_sub(gt[e], g0));
			jc->vel_sum += fps * mc_v3_norm(dv);
			jc->vel_n++;
		}
		if (jc->run >= 2) {
			jc->acc_est += mc_v3_norm(mc_v3(est[e].x - 2 * e0.x + e1.x, est[e].y - 2 * e0.y + e1.y,
							est[e].z - 2 * e0.z + e1.z));
			jc->acc_gt += mc_v3_norm(mc_v3(gt[e].x - 2 * g0.x + g1.x, gt[e].y - 2 * g0.y + g1.y,
						       gt[e].z - 2 * g0.z + g1.z));
		}
		jc->est[1][e] = e0;
		jc->gt[1][e] = g0;
		jc->est[0][e] = est[e];
		jc->gt[0][e] = gt[e];
	}
	jc->run++;
}

/* MPJPE (cm) of the --out file against the clip's ground truth; -1 when a
 * line is malformed (reported). */
static double score_estimates(const char *path, const mc_clip *clip, int *lines, jitter_check *jc)
{
	FILE *f = fopen(path, "r");
	char buf[16384];
	double sum = 0;
	int n = 0;
	*lines = 0;
	while (f && fgets(buf, sizeof(buf), f)) {
		json_error_t jerr;
		json_t *root = json_loads(buf, 0, &jerr);
		json_t *joints = json_object_get(root, "joints"), *conf = json_object_get(root, "confidence");
		int k = (int)json_integer_value(json_object_get(root, "index"));
		const char *state = json_string_value(json_object_get(root, "state"));
		CHECK_MSG(root && json_is_object(joints) && json_is_object(conf) && state && k == *lines,
			  "%s line %d: %s", path, *lines + 1, buf);
		mc_vec3 ests[NEVAL], gts[NEVAL];
		int found = 0;
		for (int e = 0; root && e < NEVAL; e++) {
			json_t *p = json_object_get(joints, evaluated[e]);
			double c = json_real_value(json_object_get(conf, evaluated[e]));
			CHECK_MSG(json_is_array(p) && json_array_size(p) == 3 && c >= 0 && c <= 1, "line %d: %s",
				  *lines + 1, evaluated[e]);
			int g = mc_clip_joint(clip, evaluated[e]);
			if (!json_is_array(p) || json_array_size(p) != 3 || g < 0)
				continue;
			mc_vec3 est = mc_v3(json_number_value(json_array_get(p, 0)), json_number_value(json_array_get(p, 1)),
					    json_number_value(json_array_get(p, 2)));
			sum += mc_v3_norm(mc_v3_sub(est, mc_clip_gt(clip, k, g)));
			n++;
			ests[found] = est;
			gts[found++] = mc_clip_gt(clip, k, g);
		}
		if (found == NEVAL)
			jitter_check_add(jc, ests, gts, clip->gt.fps);
		json_decref(root);
		(*lines)++;
	}
	if (f)
		fclose(f);
	return n ? 100 * sum / n : -1;
}

/* The JITTER line follows the RESULT line and agrees with the jitter of
 * the --out estimates computed here (to its printed digits, and to the
 * file's rounding of positions to 10 um, which second differences of
 * millimetres feel). */
static void check_jitter(const jitter_check *jc, const char *clip, const char *out)
{
	const char *res = strstr(out, "\nRESULT "), *jit = strstr(out, "\nJITTER ");
	CHECK_MSG(res && jit && jit > res, "no JITTER line after RESULT:\n%s", out);
	char name[64];
	double vel = -1, ratio = -1;
	CHECK_MSG(sscanf(line_of(out, "JITTER "), "JITTER clip=%63s vel_err_ms=%lf accel_ratio=%lf", name, &vel,
			 &ratio) == 3,
		  "'%s'", line_of(out, "JITTER "));
	double want_vel = jc->vel_n ? jc->vel_sum / jc->vel_n : -1, want_ratio = jc->acc_gt > 0 ? jc->acc_est / jc->acc_gt : -1;
	printf("JITTER printed vel %.3f m/s ratio %.3f, from --out %.4f, %.4f\n", vel, ratio, want_vel, want_ratio);
	CHECK(!strcmp(name, clip));
	CHECK_MSG(fabs(vel - want_vel) <= 0.0006 && want_vel > 0, "vel_err_ms %.3f, from --out %.4f", vel, want_vel);
	CHECK_MSG(fabs(ratio - want_ratio) <= 0.0006 + 0.005 * want_ratio && want_ratio > 0, "accel_ratio %.3f, from --out %.4f", ratio,
		  want_ratio);
}

/* The --out file at `path` scored here must give the MPJPE the tool
 * printed, over FRAMES lines, below `max_cm`; closes the clip and removes
 * the file. */
static void check_estimates(const char *path, mc_clip *clip, double mpjpe, double max_cm, const char *out)
{
	int lines;
	jitter_check jc = {0};
	double scored = score_estimates(path, clip, &lines, &jc);
	check_jitter(&jc, clip->name, out);
	printf("MPJPE printed %.2f cm, scored from --out %.4f cm over %d lines\n", mpjpe, scored, lines);
	CHECK(lines == FRAMES);
	CHECK_MSG(fabs(scored - mpjpe) <= 0.006, "printed %.2f, scored %.4f", mpjpe, scored);
	CHECK_MSG(mpjpe > 0 && mpjpe < max_cm, "MPJPE %.2f cm", mpjpe);
	mc_clip_close(clip);
	unlink(path);
}

static void test_run(void)
{
	static char out[1 << 16];
	char args[512], path[128];
	mc_err err = {{0}};
	mc_clip clip;
	CHECK_MSG(mc_clip_open("tests/data/ego_demo", false, &clip, &err) == 0, "%s", err.msg);
	snprintf(path, sizeof(path), "%s/estimates.jsonl", tmpdir);
	snprintf(args, sizeof(args),
		 "--clip tests/data/ego_demo --frames %d --reference-frames 1 --no-thesis --quiet --out %s", FRAMES, path);
	int rc = run_tool(args, out, sizeof(out));
	if (rc == 1 && strstr(out, "OpenCL")) {
		mc_clip_close(&clip);
		TEST_SKIP("no usable OpenCL device: %s", out);
	}
	CHECK_MSG(rc == 0, "exit %d:\n%s", rc, out);
	CHECK(strstr(out, "accuracy (MPJPE, cm") && strstr(out, "holding the initial pose instead"));
	CHECK(strstr(out, "error by reported joint confidence") && strstr(out, "reference backend:"));
	const char *result = line_of(out, "RESULT ");
	printf("%s\n", result);
	char name[64], device[256];
	int frames = 0;
	double mpjpe = -1, fps = -1, p99 = -1;
	int fields = sscanf(result, "RESULT clip=%63s frames=%d mpjpe_cm=%lf fps=%lf ms_p99=%lf device=%255s", name,
			    &frames, &mpjpe, &fps, &p99, device);
	CHECK_MSG(fields == 6, "RESULT line: '%s'", result);
	CHECK(!strcmp(name, "ego_demo") && frames == FRAMES && fps > 0 && p99 > 0 && !strchr(device, ' '));
	/* a loose bound: the first frames of the clip are tracked */
	check_estimates(path, &clip, mpjpe, 10, out);

	snprintf(args, sizeof(args), "--clip tests/data/ego_demo --frames 3 --reference-frames 0 --no-thesis --quiet "
				     "--simulated-detector 2");
	CHECK(run_tool(args, out, sizeof(out)) == 0);
	CHECK_MSG(strstr(out, "WARNING: simulated detector") && strstr(out, "Not the evaluation protocol"), "%s", out);
	/* the preset's rates, one overridden, and what the simulation did */
	snprintf(args, sizeof(args), "--clip tests/data/ego_demo --frames 6 --reference-frames 0 --no-thesis --quiet "
				     "--simulated-detector 2 --sim-preset ego --sim-swap 0.5");
	CHECK(run_tool(args, out, sizeof(out)) == 0);
	CHECK_MSG(strstr(out, "collapse 0.10, swap 0.50") && strstr(out, "confidences blind"), "%s", out);
	double swapped = -1;
	const char *sim = strstr(line_of(out, "SIMDET clip=ego_demo "), "swapped_pct=");
	CHECK_MSG(sim && sscanf(sim, "swapped_pct=%lf", &swapped) == 1 && swapped > 25 && swapped < 75, "%s", out);
}

/* The FLOOR line's error; -1 when the run or the line fails. */
static double floor_of(const char *clip, const char *model, char *out, size_t cap)
{
	char args[512];
	snprintf(args, sizeof(args), "--clip %s --model %s --model-floor", clip, model);
	int rc = run_tool(args, out, cap);
	double cm = -1;
	int frames = 0;
	const char *line = strstr(out, "FLOOR clip=");
	CHECK_MSG(rc == 0 && line && sscanf(strstr(line, "frames="), "frames=%d mpjpe_cm=%lf", &frames, &cm) == 2,
		  "exit %d:\n%s", rc, out);
	CHECK(frames > 0);
	return cm;
}

/* A copy of the default model with every joint's dofs locked at 0. */
static void write_locked_model(const char *path)
{
	json_error_t jerr;
	json_t *m = json_load_file("config/models/default.json", 0, &jerr);
	CHECK_MSG(m, "default.json:%d: %s", jerr.line, jerr.text);
	size_t i, k;
	json_t *joint, *dof;
	json_array_foreach(json_object_get(m, "joints"), i, joint) json_array_foreach(json_object_get(joint, "dofs"), k, dof)
	{
		json_object_set_new(dof, "min_deg", json_real(0));
		json_object_set_new(dof, "max_deg", json_real(0));
	}
	CHECK(json_dump_file(m, path, 0) == 0);
	json_decref(m);
}

/* --model-floor: the body model fitted to each frame's ground truth, no
 * tracking.  Both layouts fit within a few centimetres; a model whose
 * joints cannot turn stays far off (so the fit is what moves the joints).
 * test_unscored_clip checks that a clip without gt.json is refused. */
static void test_model_floor(void)
{
	static char out[1 << 15];
	char locked[128];
	double ego = floor_of("tests/data/ego_demo", "config/models/default.json", out, sizeof(out));
	CHECK_MSG(strstr(out, "left_wrist") && !strstr(out, "RESULT "), "%s", out);
	double outside = floor_of("tests/data/outside_demo", "config/models/default.json", out, sizeof(out));
	snprintf(locked, sizeof(locked), "%s/locked.json", tmpdir);
	write_locked_model(locked);
	double stiff = floor_of("tests/data/ego_demo", locked, out, sizeof(out));
	printf("model floor: ego_demo %.2f cm (joints locked: %.2f), outside_demo %.2f cm\n", ego, stiff, outside);
	CHECK(ego > 0 && ego < 3 && outside > 0 && outside < 3);
	CHECK(stiff > ego + 5);
	unlink(locked);
}

/* The outside-in layout (tests/data/outside_demo: cameras.json, camK/):
 * detected, tracked with a free root and scored in the world frame; the
 * --out joints are world coordinates (scored here against joints_world);
 * --cameras picks a subset and says so in the RESULT line. */
static void test_outside_in(void)
{
	static char out[1 << 16];
	char args[512], path[128];
	mc_err err = {{0}};
	mc_clip clip;
	CHECK_MSG(mc_clip_open("tests/data/outside_demo", false, &clip, &err) == 0, "%s", err.msg);
	CHECK(clip.layout == MC_CLIP_OUTSIDE && clip.rig.ncams == 4 && clip.rig.kind == MC_RIG_OUTSIDE_IN);
	snprintf(path, sizeof(path), "%s/outside.jsonl", tmpdir);
	snprintf(args, sizeof(args),
		 "--clip tests/data/outside_demo --frames %d --reference-frames 0 --no-thesis --quiet --out %s", FRAMES,
		 path);
	int rc = run_tool(args, out, sizeof(out));
	CHECK_MSG(rc == 0, "exit %d:\n%s", rc, out);
	CHECK_MSG(strstr(out, "outside-in, 4 cameras: cam0 cam1 cam2 cam3") && strstr(out, "world frame"), "%s", out);
	const char *result = line_of(out, "RESULT ");
	printf("%s\n", result);
	double mpjpe = -1;
	int ncams = 0;
	const char *cams = strstr(result, " cameras=");
	CHECK_MSG(sscanf(result, "RESULT clip=outside_demo frames=%*d mpjpe_cm=%lf", &mpjpe) == 1, "%s", result);
	CHECK_MSG(cams && sscanf(cams, " cameras=%d", &ncams) == 1 && ncams == 4, "%s", result);
	check_estimates(path, &clip, mpjpe, 8, out);

	snprintf(args, sizeof(args), "--clip tests/data/outside_demo --frames 3 --reference-frames 0 --no-thesis "
				     "--quiet --cameras 1,2");
	CHECK_MSG(run_tool(args, out, sizeof(out)) == 0 && strstr(out, "2 cameras: cam1 cam2") &&
			  strstr(line_of(out, "RESULT "), " cameras=2"),
		  "%s", out);
	CHECK(run_tool("--clip tests/data/outside_demo --cameras 0,9", out, sizeof(out)) != 0 &&
	      strstr(out, "--cameras '0,9': expected distinct camera indices 0..3"));
	CHECK(run_tool("--clip tests/data/outside_demo --cameras 1,1", out, sizeof(out)) != 0 &&
	      strstr(out, "expected distinct camera indices"));
}

/* The whole of a file, NUL-terminated, in buf; false when unreadable or
 * longer than cap - 1. */
static bool slurp(const char *path, char *buf, size_t cap)
{
	FILE *f = fopen(path, "r");
	size_t n = f ? fread(buf, 1, cap, f) : 0;
	if (f)
		fclose(f);
	if (!f || n >= cap)
		return false;
	buf[n] = 0;
	return true;
}

/* --detector: the detection of frame set k + 1 runs on its own thread while
 * k is tracked (as in mocapd), or before it with --detector-serial; the
 * keypoints are the same, so the estimates must be identical. */
static void test_detector_pipelined(void)
{
	static char out[1 << 16], a[1 << 18], b[1 << 18];
	const char *model = "config/models/ego_detector.onnx";
	if (access(model, R_OK) != 0) {
		printf("test_detector_pipelined: %s not found, skipped\n", model);
		return;
	}
	char args[512], path[2][128];
	for (int serial = 0; serial < 2; serial++) {
		snprintf(path[serial], sizeof(path[serial]), "%s/detector%d.jsonl", tmpdir, serial);
		snprintf(args, sizeof(args),
			 "--clip tests/data/ego_demo --frames 8 --reference-frames 0 --no-thesis --quiet --detector %s "
			 "--out %s%s",
			 model, path[serial], serial ? " --detector-serial" : "");
		int rc = run_tool(args, out, sizeof(out));
		CHECK_MSG(rc == 0, "exit %d:\n%s", rc, out);
		CHECK_MSG(strstr(out, serial ? "serial (detect, then track)" : "pipelined (as in mocapd)") &&
				  strstr(out, "DETECT2D clip=ego_demo") && strstr(line_of(out, "RESULT "), "RESULT clip=ego_demo frames=8"),
			  "%s", out);
	}
	CHECK(slurp(path[0], a, sizeof(a)) && slurp(path[1], b, sizeof(b)));
	CHECK_MSG(strlen(a) > 100 && strcmp(a, b) == 0, "pipelined and serial estimates differ:\n%s\n---\n%s", a, b);
	unlink(path[0]);
	unlink(path[1]);
	CHECK(run_tool("--clip tests/data/ego_demo --detector /nonexistent/model.onnx", out, sizeof(out)) != 0 &&
	      strstr(out, "/nonexistent/model.onnx"));
}

/* --detector-flip: the detector line says so, and the keypoints the tracker
 * is given are not the plain ones (mc_detector_set_flip took effect). */
static void test_detector_flip(void)
{
	static char out[1 << 16], kp[2][1 << 18];
	const char *model = "config/models/ego_detector.onnx";
	if (access(model, R_OK) != 0)
		return;
	char args[512], path[128];
	snprintf(path, sizeof(path), "%s/flip.jsonl", tmpdir);
	for (int flip = 0; flip < 2; flip++) {
		snprintf(args, sizeof(args),
			 "--clip tests/data/ego_demo --frames 2 --reference-frames 0 --no-thesis --quiet --detector %s "
			 "--keypoints-out %s%s",
			 model, path, flip ? " --detector-flip" : "");
		int rc = run_tool(args, out, sizeof(out));
		CHECK_MSG(rc == 0 && strstr(line_of(out, "RESULT "), "RESULT clip=ego_demo frames=2"), "exit %d:\n%s", rc,
			  out);
		CHECK_MSG(!strstr(line_of(out, "detector: "), ", flip test,") == !flip, "%s", line_of(out, "detector: "));
		CHECK(slurp(path, kp[flip], sizeof(kp[flip])) && strlen(kp[flip]) > 100);
	}
	CHECK_MSG(strcmp(kp[0], kp[1]) != 0, "the same keypoints with and without --detector-flip");
	unlink(path);
}

/* --frame-step N: every Nth frame set is tracked and scored (cameras at
 * 1/N of the clip's rate), without the detector and with it (pipelined). */
static void test_frame_step(void)
{
	static char out[1 << 16], text[1 << 18];
	char args[512], path[128];
	snprintf(path, sizeof(path), "%s/step.jsonl", tmpdir);
	snprintf(args, sizeof(args),
		 "--clip tests/data/ego_demo --frames 8 --frame-step 3 --reference-frames 0 --no-thesis --quiet --out %s",
		 path);
	int rc = run_tool(args, out, sizeof(out));
	CHECK_MSG(rc == 0 && strstr(line_of(out, "RESULT "), "RESULT clip=ego_demo frames=3 "), "exit %d:\n%s", rc, out);
	CHECK(slurp(path, text, sizeof(text)));
	int lines = 0;
	for (const char *p = text; (p = strstr(p, "{\"index\": ")); p++) {
		int k = atoi(p + strlen("{\"index\": "));
		CHECK_MSG(k == 3 * lines, "estimate %d is of frame set %d, expected %d", lines, k, 3 * lines);
		lines++;
	}
	CHECK_MSG(lines == 3, "%d estimates written, expected 3", lines);
	unlink(path);
	const char *model = "config/models/ego_detector.onnx";
	if (access(model, R_OK) != 0)
		return;
	snprintf(args, sizeof(args),
		 "--clip tests/data/ego_demo --frames 8 --frame-step 2 --reference-frames 0 --no-thesis --quiet "
		 "--detector %s",
		 model);
	rc = run_tool(args, out, sizeof(out));
	CHECK_MSG(rc == 0 && strstr(line_of(out, "RESULT "), "RESULT clip=ego_demo frames=4 "), "exit %d:\n%s", rc, out);
}

/* One --keypoints-out line: its views' keypoints, checked for shape and
 * against the clip (each inside its camera's image); with `exact`, every
 * keypoint must be its joint's ground truth projected into the camera (the
 * simulated detector without noise), confidence 1.  Returns the number of
 * keypoints, -1 when the line is malformed. */
static int check_keypoint_line(const char *line, int want_k, const mc_clip *clip, bool exact, int *n_evaluated)
{
	json_error_t jerr;
	json_t *root = json_loads(line, 0, &jerr), *views = json_object_get(root, "views");
	int n = 0;
	bool ok = root && json_integer_value(json_object_get(root, "index")) == want_k && json_is_array(views) &&
		  (int)json_array_size(views) == clip->rig.ncams;
	for (int c = 0; ok && c < clip->rig.ncams; c++) {
		const mc_camera *cam = &clip->rig.cams[c];
		json_t *view = json_array_get(views, (size_t)c), *joints = json_object_get(view, "joints"), *p;
		const char *name;
		ok = json_is_object(joints) && !strcmp(json_string_value(json_object_get(view, "camera")), cam->name);
		json_object_foreach(joints, name, p)
		{
			double u = json_number_value(json_array_get(p, 0)), v = json_number_value(json_array_get(p, 1));
			double conf = json_number_value(json_array_get(p, 2)), tu = -1e9, tv = -1e9;
			int g = mc_clip_joint(clip, name);
			if (g >= 0)
				mc_camera_project_rig(cam, mc_clip_gt(clip, want_k, g),
						  &tu, &tv);
			bool good = json_array_size(p) == 3 && conf >= 0 && conf <= 1 && u > -0.5 && v > -0.5 && u < cam->width &&
				    v < cam->height;
			if (exact)
				good = good && conf == 1 && fabs(u - tu) < 1e-3 && fabs(v - tv) < 1e-3;
			CHECK_MSG(good, "frame set %d, %s, %s: [%g, %g, %g], truth at (%g, %g)", want_k, cam->name, name, u, v,
				  conf, tu, tv);
			n++;
			for (int e = 0; e < NEVAL; e++)
				*n_evaluated += !strcmp(name, evaluated[e]);
		}
	}
	CHECK_MSG(ok, "keypoints line %d: %s", want_k, line);
	json_decref(root);
	return ok ? n : -1;
}

/* Checks a --keypoints-out file of `lines` frame sets; returns the number
 * of keypoints in it, and in n_evaluated those of the evaluated joints. */
static int check_keypoints_file(const char *path, const mc_clip *clip, int lines, bool exact, int *n_evaluated)
{
	FILE *f = fopen(path, "r");
	static char buf[1 << 16];
	int k = 0, n = 0;
	while (f && fgets(buf, sizeof(buf), f)) {
		int m = check_keypoint_line(buf, k++, clip, exact, n_evaluated);
		n += m > 0 ? m : 0;
	}
	if (f)
		fclose(f);
	CHECK_MSG(f && k == lines, "%s: %d lines, expected %d", path, k, lines);
	unlink(path);
	return n;
}

/* --keypoints-out: the simulated detector without noise gives the projected
 * ground truth, 15 % missed; the detector's keypoints of the evaluated
 * joints are as many as its 2D report counted (DETECT2D reported=). */
static void test_keypoints_out(void)
{
	static char out[1 << 16];
	char args[512], path[128];
	mc_err err = {{0}};
	mc_clip clip;
	CHECK_MSG(mc_clip_open("tests/data/ego_demo", false, &clip, &err) == 0, "%s", err.msg);
	snprintf(path, sizeof(path), "%s/keypoints.jsonl", tmpdir);
	snprintf(args, sizeof(args),
		 "--clip tests/data/ego_demo --frames 6 --reference-frames 0 --no-thesis --quiet --simulated-detector 0 "
		 "--keypoints-out %s",
		 path);
	int rc = run_tool(args, out, sizeof(out));
	CHECK_MSG(rc == 0, "exit %d:\n%s", rc, out);
	int n_eval = 0, n = check_keypoints_file(path, &clip, 6, true, &n_eval);
	int most = 6 * SIM_HEAD_JOINTS * clip.rig.ncams;
	printf("simulated: %d keypoints of at most %d\n", n, most);
	CHECK_MSG(n > 0.6 * most && n < most, "%d keypoints of at most %d", n, most);
	const char *model = "config/models/ego_detector.onnx";
	if (access(model, R_OK) == 0) {
		snprintf(args, sizeof(args),
			 "--clip tests/data/ego_demo --frames 4 --reference-frames 0 --no-thesis --quiet --detector %s "
			 "--keypoints-out %s",
			 model, path);
		rc = run_tool(args, out, sizeof(out));
		CHECK_MSG(rc == 0, "exit %d:\n%s", rc, out);
		int reported = -1;
		const char *d2 = strstr(line_of(out, "DETECT2D "), " reported=");
		CHECK(d2 && sscanf(d2, " reported=%d", &reported) == 1);
		n_eval = 0;
		n = check_keypoints_file(path, &clip, 4, false, &n_eval);
		printf("detector: %d keypoints, %d of evaluated joints, DETECT2D reported=%d\n", n, n_eval, reported);
		CHECK_MSG(n_eval == reported && reported > 0, "%d keypoints of evaluated joints, %d reported", n_eval,
			  reported);
	}
	/* The reference backend's frames (--reference-frames, tracked after
	 * the clip) leave the overlays alone: frame 0's was overwritten with
	 * the reference run's pose.  Same seed, so the same overlay with and
	 * without them. */
	for (int ref = 0; ref <= 3; ref += 3) {
		snprintf(args, sizeof(args),
			 "--clip tests/data/ego_demo --frames 2 --reference-frames %d --no-thesis --quiet "
			 "--simulated-detector 0 --overlay-dir %s/ov%d --overlay-every 2",
			 ref, tmpdir, ref);
		char dir[128];
		snprintf(dir, sizeof(dir), "%s/ov%d", tmpdir, ref);
		CHECK(mkdir(dir, 0755) == 0);
		rc = run_tool(args, out, sizeof(out));
		CHECK_MSG(rc == 0, "exit %d:\n%s", rc, out);
	}
	snprintf(args, sizeof(args), "cmp -s %s/ov0/overlay_00000.png %s/ov3/overlay_00000.png", tmpdir, tmpdir);
	CHECK_MSG(system(args) == 0, "frame 0's overlay differs when the reference backend runs after the clip");
	snprintf(args, sizeof(args), "rm -r %s/ov0 %s/ov3", tmpdir, tmpdir);
	CHECK(system(args) == 0);
	CHECK(run_tool("--clip tests/data/ego_demo --frames 2 --keypoints-out /nonexistent/k.jsonl", out, sizeof(out)) != 0 &&
	      strstr(out, "/nonexistent/k.jsonl: cannot write"));
	mc_clip_close(&clip);
}

/* The joint names of a --keypoints-out file, each once, in names (at
 * most cap of them, separated by spaces). */
static void keypoint_names(const char *path, char *names, size_t cap)
{
	FILE *f = fopen(path, "r");
	static char buf[1 << 16];
	names[0] = 0;
	while (f && fgets(buf, sizeof(buf), f)) {
		json_t *root = json_loads(buf, 0, NULL), *view, *p;
		size_t i;
		const char *name;
		json_array_foreach (json_object_get(root, "views"), i, view)
			json_object_foreach (json_object_get(view, "joints"), name, p) {
				char word[64];
				snprintf(word, sizeof(word), " %s ", name);
				size_t len = strlen(names);
				if (!strstr(names, word) && len + strlen(word) < cap)
					snprintf(names + len, cap - len, "%s", len ? word + 1 : word);
			}
		json_decref(root);
	}
	if (f)
		fclose(f);
	unlink(path);
}

/* The simulated detector gives the joints the rig's shipped detector
 * gives: on a head rig the runtime's 18 (head_top, spine and pelvis
 * besides the evaluated ones), outside-in MoveNet's 12 (no neck, no toes).
 * Until stop 61 it gave the 15 evaluated joints on both. */
static void test_simulated_joints(void)
{
	static char out[1 << 16];
	char args[512], path[128], names[1024];
	snprintf(path, sizeof(path), "%s/sim.jsonl", tmpdir);
	const char *clips[] = {"ego_demo", "outside_demo"};
	for (int i = 0; i < 2; i++) {
		snprintf(args, sizeof(args),
			 "--clip tests/data/%s --frames 6 --reference-frames 0 --no-thesis --quiet "
			 "--simulated-detector 0 --keypoints-out %s",
			 clips[i], path);
		int rc = run_tool(args, out, sizeof(out));
		CHECK_MSG(rc == 0, "exit %d:\n%s", rc, out);
		keypoint_names(path, names, sizeof(names));
		printf("%s: simulated joints:%s\n", clips[i], names);
		bool outside = i == 1;
		CHECK_MSG(strstr(names, " left_wrist ") && strstr(names, " right_knee "), "%s:%s", clips[i], names);
		CHECK_MSG(!strstr(names, " pelvis ") == outside && !strstr(names, " spine ") == outside &&
				  !strstr(names, " head_top ") == outside,
			  "%s:%s", clips[i], names);
		CHECK_MSG(!strstr(names, " neck ") == outside && !strstr(names, " left_toe ") == outside, "%s:%s",
			  clips[i], names);
	}
}

/* The largest distance between a joint of one --out file and the same
 * joint of the same line of another (metres); infinite when their lines
 * or joints differ. */
static double max_joint_difference(const char *a, const char *b)
{
	double worst = 0;
	while (*a && *b) {
		json_t *ja = json_loadb(a, strcspn(a, "\n"), 0, NULL), *jb = json_loadb(b, strcspn(b, "\n"), 0, NULL);
		const json_t *joints_a = json_object_get(ja, "joints"), *joints_b = json_object_get(jb, "joints");
		if (!joints_a || json_object_size(joints_a) != json_object_size(joints_b))
			worst = INFINITY;
		const char *name;
		const json_t *pa;
		json_object_foreach ((json_t *)joints_a, name, pa) {
			const json_t *pb = json_object_get(joints_b, name);
			double d2 = pb ? 0 : INFINITY;
			for (int i = 0; i < 3 && pb; i++) {
				double d = json_number_value(json_array_get(pa, i)) - json_number_value(json_array_get(pb, i));
				d2 += d * d;
			}
			worst = fmax(worst, sqrt(d2));
		}
		json_decref(ja);
		json_decref(jb);
		a += strcspn(a, "\n") + (a[strcspn(a, "\n")] != 0);
		b += strcspn(b, "\n") + (b[strcspn(b, "\n")] != 0);
	}
	return *a || *b ? INFINITY : worst;
}

/* Writes text to tmpdir/name; its path in path. */
static void write_tmp(const char *name, const char *text, char *path, size_t cap)
{
	snprintf(path, cap, "%s/%s", tmpdir, name);
	FILE *f = fopen(path, "w");
	CHECK(f && fputs(text, f) >= 0);
	if (f)
		fclose(f);
}

/* --keypoints-in: a file of keypoints stands in for the detector.  What
 * the tracker is given (--keypoints-out) is the file to the byte, frame set
 * by frame set, and the same keypoints give the estimates they gave when
 * simulated; a file without a frame set's line gives it none; bad files
 * are refused naming the line. */
static void test_keypoints_in(void)
{
	static char out[1 << 16], a[1 << 17], b[1 << 17];
	char args[1024], given[128], replayed[128], est[2][128], bad[160];
	const char *common = "--clip tests/data/ego_demo --frames 6 --reference-frames 0 --no-thesis --quiet --seed 3";
	snprintf(given, sizeof(given), "%s/given.jsonl", tmpdir);
	snprintf(replayed, sizeof(replayed), "%s/replayed.jsonl", tmpdir);
	for (int i = 0; i < 2; i++)
		snprintf(est[i], sizeof(est[i]), "%s/est%d.jsonl", tmpdir, i);
	snprintf(args, sizeof(args), "%s --simulated-detector 2 --keypoints-out %s --out %s", common, given, est[0]);
	CHECK_MSG(run_tool(args, out, sizeof(out)) == 0, "%s", out);
	snprintf(args, sizeof(args), "%s --keypoints-in %s --keypoints-out %s --out %s", common, given, replayed, est[1]);
	CHECK_MSG(run_tool(args, out, sizeof(out)) == 0 && strstr(out, "keypoints: "), "%s", out);
	CHECK(slurp(given, a, sizeof(a)) && slurp(replayed, b, sizeof(b)));
	CHECK_MSG(strlen(a) > 1000 && !strcmp(a, b), "the tracker was not given the file's keypoints");
	/* 1e-4 px of rounding in the file: the estimates within 1 mm */
	CHECK(slurp(est[0], a, sizeof(a)) && slurp(est[1], b, sizeof(b)));
	CHECK_MSG(max_joint_difference(a, b) < 1e-3, "estimates %.4f m apart", max_joint_difference(a, b));

	/* only frame set 1 given: the others get none */
	CHECK(slurp(given, a, sizeof(a)));
	char *second = strchr(a, '\n') + 1;
	second[strcspn(second, "\n") + 1] = 0;
	write_tmp("one.jsonl", second, bad, sizeof(bad));
	snprintf(args, sizeof(args), "%s --keypoints-in %s --keypoints-out %s", common, bad, replayed);
	CHECK_MSG(run_tool(args, out, sizeof(out)) == 0, "%s", out);
	CHECK(slurp(replayed, b, sizeof(b)));
	CHECK_MSG(strstr(b, second) && strstr(b, "{\"index\": 0, \"views\": [{\"camera\": \"left\", \"joints\": {}}"),
		  "%s", b);

	static const struct {
		const char *text, *error;
	} bad_files[] = {
		{"{\"index\": 0, \"views\": []}\n{\"index\": 0, \"views\": []}\n", ":2: index 0 given twice"},
		{"\n{\"index\": 0, \"views\": [{\"camera\": \"left\", \"joints\": {\"nose\": [1, 2, 0.5]}}]}\n",
		 ":2: joint \"nose\": the body model has no such joint"},
		{"{\"index\": 0, \"views\": [{\"camera\": \"left\", \"joints\": {\"neck\": [1, 2, 1.5]}}]}\n",
		 ":1: joint \"neck\": expected [u, v, confidence]"},
		{"{\"index\": 99, \"views\": []}\n", ":1: index: "},
		{"{\"index\": 0, \"views\": [\n", ":1:"},
		{"{\"index\": 0, \"views\": [{\"camera\": \"cam7\", \"joints\": {}}]}\n", "no view names a camera"},
	};
	for (size_t i = 0; i < sizeof(bad_files) / sizeof(bad_files[0]); i++) {
		write_tmp("bad.jsonl", bad_files[i].text, bad, sizeof(bad));
		snprintf(args, sizeof(args), "%s --keypoints-in %s", common, bad);
		CHECK_MSG(run_tool(args, out, sizeof(out)) == 1 && strstr(out, bad) && strstr(out, bad_files[i].error),
			  "file %zu: %s", i, out);
	}
	snprintf(args, sizeof(args), "%s --keypoints-in %s --simulated-detector 2", common, given);
	CHECK(run_tool(args, out, sizeof(out)) == 2 && strstr(out, "exclude each other"));
	snprintf(args, sizeof(args), "%s --keypoints-in %s/none.jsonl", common, tmpdir);
	CHECK(run_tool(args, out, sizeof(out)) == 1 && strstr(out, "none.jsonl: cannot read"));
	unlink(bad);
	unlink(given);
	unlink(replayed);
	unlink(est[0]);
	unlink(est[1]);
	snprintf(args, sizeof(args), "%s/one.jsonl", tmpdir);
	unlink(args);
}

/* A clip without gt.json (real footage): tests/data/outside_demo copied
 * without it opens with the frame sets found on disk and no truth; the
 * tool tracks it from the detections and writes --out, scores nothing
 * (mpjpe_cm=nan, no JITTER or DETECT2D line) and still says when tracking
 * started and the states; without --init detect it says what is missing. */
static void test_unscored_clip(void)
{
	static char out[1 << 16], text[1 << 18];
	char dir[128], cmd[512], args[768], path[160];
	snprintf(dir, sizeof(dir), "%s/nogt", tmpdir);
	snprintf(cmd, sizeof(cmd), "cp -r tests/data/outside_demo %s && rm %s/gt.json %s/cam2/00029.jpg", dir, dir, dir);
	CHECK_MSG(system(cmd) == 0, "%s", cmd);
	mc_err err = {{0}};
	mc_clip clip;
	CHECK_MSG(mc_clip_open(dir, false, &clip, &err) == 0, "%s", err.msg);
	/* 30 frames, but camera 2 lacks the last */
	CHECK_MSG(!clip.has_gt && clip.gt.nframes == 29 && clip.gt.fps == 30 && clip.rig.ncams == 4, "%d frames",
		  clip.gt.nframes);
	CHECK(mc_clip_joint(&clip, "neck") < 0);
	mc_clip_close(&clip);
	snprintf(args, sizeof(args), "--clip %s --frames 2 --no-thesis", dir);
	CHECK_MSG(run_tool(args, out, sizeof(out)) == 1 && strstr(out, "has no gt.json") && strstr(out, "--init detect"),
		  "%s", out);
	snprintf(args, sizeof(args), "--clip %s --model-floor", dir);
	CHECK_MSG(run_tool(args, out, sizeof(out)) == 1 && strstr(out, "has no gt.json: --model-floor"), "%s", out);
	snprintf(args, sizeof(args), "--clip %s --frames 2 --init detect --simulated-detector 2", dir);
	CHECK_MSG(run_tool(args, out, sizeof(out)) == 1 && strstr(out, "--simulated-detector projects the ground truth"),
		  "%s", out);
	const char *model = "config/models/outside_detector.onnx";
	if (access(model, R_OK) == 0) {
		snprintf(path, sizeof(path), "%s/nogt.jsonl", tmpdir);
		snprintf(args, sizeof(args),
			 "--clip %s --frames 6 --init detect --detector %s --reference-frames 0 --no-thesis --out %s", dir,
			 model, path);
		int rc = run_tool(args, out, sizeof(out));
		CHECK_MSG(rc == 0, "exit %d:\n%s", rc, out);
		CHECK_MSG(strstr(out, "first pose at frame set ") && strstr(out, "(states: ") &&
				  strstr(out, "not scored") && !strstr(out, "\nJITTER ") && !strstr(out, "\nDETECT2D ") &&
				  !strstr(out, "BONES"),
			  "%s", out);
		CHECK_MSG(strstr(line_of(out, "RESULT "), "RESULT clip=nogt frames=6 mpjpe_cm=nan "), "%s",
			  line_of(out, "RESULT "));
		int lines = 0;
		CHECK(slurp(path, text, sizeof(text)));
		for (const char *p = text; (p = strstr(p, "{\"index\": ")); p++)
			CHECK(atoi(p + strlen("{\"index\": ")) == lines++);
		CHECK_MSG(lines == 6, "%d estimates written", lines);
		unlink(path);
	}
	snprintf(cmd, sizeof(cmd), "rm -r %s", dir);
	CHECK(system(cmd) == 0);
}

static void test_bad_command_lines(void)
{
	static char out[1 << 14];
	CHECK(run_tool("--frames 3", out, sizeof(out)) != 0 && strstr(out, "--clip DIR is required"));
	CHECK(run_tool("-h", out, sizeof(out)) == 0 && strstr(out, "usage: mocap-bench"));
	CHECK(run_tool("-V", out, sizeof(out)) == 0 && strstr(out, "mocap-bench "));
	CHECK(run_tool("--bogus", out, sizeof(out)) == 2);
	CHECK(run_tool("--clip /nonexistent/clip", out, sizeof(out)) != 0 && strstr(out, "/nonexistent/clip"));
	CHECK_MSG(run_tool("--clip tests/data/ego_demo --frames many", out, sizeof(out)) != 0 && strstr(out, "frames"),
		  "%s", out);
	CHECK(run_tool("--clip tests/data/ego_demo --sim-collapse 0.2", out, sizeof(out)) == 2 &&
	      strstr(out, "--sim-* options need --simulated-detector PX"));
	CHECK(run_tool("--clip tests/data/ego_demo --simulated-detector 2 --sim-preset lab", out, sizeof(out)) == 2 &&
	      strstr(out, "--sim-preset: expected ego, outside or none, got 'lab'"));
	CHECK(run_tool("--clip tests/data/ego_demo --simulated-detector 2 --sim-outlier 1.5", out, sizeof(out)) == 2 &&
	      strstr(out, "--sim-outlier: expected a rate in [0, 1]"));
	CHECK(run_tool("--clip tests/data/ego_demo --simulated-detector 2 --sim-collapse 0.8 --sim-swap 0.3", out,
		       sizeof(out)) == 2 &&
	      strstr(out, "add up to more than 1"));
	CHECK(run_tool("--clip tests/data/ego_demo --backend cuda", out, sizeof(out)) != 0 &&
	      strstr(out, "--backend: expected opencl or reference"));
	CHECK_MSG(run_tool("--clip tests/data/ego_demo --overlay-dir /nonexistent/x/y", out, sizeof(out)) != 0 &&
			  strstr(out, "--overlay-dir /nonexistent/x/y"),
		  "%s", out);
}

int main(int argc, char **argv)
{
	(void)argc;
	mc_test_find_tool(argv[0], "mocap-bench", tool, sizeof(tool));
	if (access("tests/data/ego_demo/gt.json", R_OK) != 0)
		TEST_SKIP("run from the repository root (tests/data/ego_demo not found)");
	snprintf(tmpdir, sizeof(tmpdir), "/tmp/mocap-bench-test-XXXXXX");
	if (!mkdtemp(tmpdir)) {
		perror("mkdtemp");
		return 1;
	}
	test_bad_command_lines();
	test_run();
	test_model_floor();
	test_outside_in();
	test_detector_pipelined();
	test_detector_flip();
	test_frame_step();
	test_keypoints_out();
	test_simulated_joints();
	test_keypoints_in();
	test_unscored_clip();
	rmdir(tmpdir);
	return mc_test_finish("test_bench_tool");
}
