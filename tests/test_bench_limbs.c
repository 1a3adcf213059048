/* mocap-bench's LIMBS line (docs/man/mocap-bench.1.scd): for each limb's
 * end, the longest run of frame sets with the joint more than 20 cm from
 * the truth, over every frame set and over those where the truth's joint
 * projects into some camera's image (issue 35: "a limb in view is never
 * lost for more than 0.5 s"; frame sets out of view neither count nor end
 * a run).  Both are computed here again from the --out estimates, the
 * clip's gt.json and its cameras, on the bundled clip tracked without its
 * colour term and without keypoints, so that the pose holds its first
 * frame set's and the limbs that move are lost; and on a copy whose
 * principal point is moved off the image, where limbs leave the view. */
#include "eval/mc_clip.h"
#include "test_util.h"

#include <jansson.h>
#include <string.h>
#include <unistd.h>

#define LOST_M 0.20
static const char *const limb_ends[] = {"left_wrist", "right_wrist", "left_ankle", "right_ankle"};
#define NLIMBS 4

static char tool[4096];

typedef struct {
	int run, longest, view_run, view_longest, out_of_view;
} limb_runs;

static void count(bool lost, int *run, int *longest)
{
	*run = lost ? *run + 1 : 0;
	if (*run > *longest)
		*longest = *run;
}

/* Reads the --out file line by line into each limb's runs; returns the
 * lines read. */
static int runs_from_estimates(const char *path, const mc_clip *clip, limb_runs *runs)
{
	FILE *f = fopen(path, "r");
	char buf[16384];
	int lines = 0;
	CHECK_MSG(f, "%s not written", path);
	while (f && fgets(buf, sizeof(buf), f)) {
		json_error_t jerr;
		json_t *root = json_loads(buf, 0, &jerr);
		json_t *joints = json_object_get(root, "joints");
		int k = (int)json_integer_value(json_object_get(root, "index"));
		CHECK_MSG(json_is_object(joints), "%s line %d: %s", path, lines + 1, buf);
		for (int l = 0; l < NLIMBS && json_is_object(joints); l++) {
			json_t *p = json_object_get(joints, limb_ends[l]);
			int g = mc_clip_joint(clip, limb_ends[l]);
			CHECK_MSG(json_is_array(p) && g >= 0, "line %d: %s", lines + 1, limb_ends[l]);
			if (!json_is_array(p) || g < 0)
				continue;
			mc_vec3 est = mc_v3(json_number_value(json_array_get(p, 0)), json_number_value(json_array_get(p, 1)),
					    json_number_value(json_array_get(p, 2)));
			mc_vec3 truth = mc_clip_gt(clip, k, g);
			bool lost = mc_v3_norm(mc_v3_sub(est, truth)) > LOST_M;
			count(lost, &runs[l].run, &runs[l].longest);
			if (mc_rig_sees(&clip->rig, truth))
				count(lost, &runs[l].view_run, &runs[l].view_longest);
			else
				runs[l].out_of_view++;
		}
		json_decref(root);
		lines++;
	}
	if (f)
		fclose(f);
	return lines;
}

/* Checks the printed LIMBS line (its first character at `line`) against
 * the runs computed here; returns the number of limbs lost at some time
 * and the printed worst_s and worst_in_view_s. */
static int check_printed(const char *line, const limb_runs *runs, double dt, double *worst_s, double *view_s)
{
	int worst = 0, worst_view = 0, lost = 0;
	for (int l = 0; l < NLIMBS; l++) {
		char key[64];
		double s = -1;
		snprintf(key, sizeof(key), " %s=", limb_ends[l]);
		const char *at = strstr(line, key);
		CHECK_MSG(at && sscanf(at + strlen(key), "%lf", &s) == 1, "%s missing", limb_ends[l]);
		printf("  %-11s printed %.2f s, from --out %.2f s (in view %.2f s, %d frame sets out of every view)\n",
		       limb_ends[l], s, runs[l].longest * dt, runs[l].view_longest * dt, runs[l].out_of_view);
		CHECK_MSG(fabs(s - runs[l].longest * dt) < 0.006, "%s: printed %.2f s", limb_ends[l], s);
		worst = runs[l].longest > worst ? runs[l].longest : worst;
		worst_view = runs[l].view_longest > worst_view ? runs[l].view_longest : worst_view;
		lost += runs[l].longest > 0;
	}
	const char *w = strstr(line, " worst_s=");
	CHECK_MSG(w && sscanf(w, " worst_s=%lf worst_in_view_s=%lf", worst_s, view_s) == 2, "worst_s, worst_in_view_s");
	CHECK_MSG(fabs(*worst_s - worst * dt) < 0.006, "worst_s %.2f, from --out %.2f", *worst_s, worst * dt);
	CHECK_MSG(fabs(*view_s - worst_view * dt) < 0.006, "worst_in_view_s %.2f, from --out %.2f", *view_s,
		  worst_view * dt);
	CHECK(*view_s <= *worst_s);
	return lost;
}

/* Tracks `clip_dir` held still and checks its LIMBS line; returns the
 * number of limbs lost at some time (-1 when the run failed) and the
 * printed worst_s and worst_in_view_s (where not NULL). */
static int check_limbs_line(const char *clip_dir, const char *extra, double *worst_out, double *view_out)
{
	static char out[1 << 16];
	char cmd[8192], path[128], tmpdir[64];
	mc_err err = {{0}};
	mc_clip clip;
	snprintf(tmpdir, sizeof(tmpdir), "/tmp/mocap-bench-limbs-XXXXXX");
	CHECK_MSG(mkdtemp(tmpdir) != NULL, "mkdtemp");
	snprintf(path, sizeof(path), "%s/estimates.jsonl", tmpdir);
	snprintf(cmd, sizeof(cmd), "%s --clip %s --reference-frames 0 --no-thesis --quiet --lambda-color 0 %s --out %s 2>&1",
		 tool, clip_dir, extra, path);
	int rc = mc_test_run(cmd, out, sizeof(out)), lost = -1;
	if (rc == 1 && strstr(out, "OpenCL"))
		TEST_SKIP("no usable OpenCL device: %s", out);
	CHECK_MSG(rc == 0, "exit %d:\n%s", rc, out);
	const char *line = strstr(out, "\nLIMBS clip=");
	CHECK_MSG(line, "no LIMBS line:\n%s", out);
	bool opened = rc == 0 && line && mc_clip_open(clip_dir, false, &clip, &err) == 0;
	CHECK_MSG(opened || rc != 0 || !line, "%s: %s", clip_dir, err.msg);
	if (opened) {
		limb_runs runs[NLIMBS] = {{0}};
		int lines = runs_from_estimates(path, &clip, runs);
		printf("%s: %d frame sets; %.*s\n", clip_dir, lines, (int)strcspn(line + 1, "\n"), line + 1);
		double worst_s = -1, view_s = -1;
		lost = check_printed(line + 1, runs, 1.0 / clip.gt.fps, &worst_s, &view_s);
		if (worst_out)
			*worst_out = worst_s, *view_out = view_s;
		mc_clip_close(&clip);
	}
	unlink(path);
	rmdir(tmpdir);
	return lost;
}

/* A copy of clip `src` at `dir` whose cameras' principal point is moved
 * to x = cx: the same images and truth, but a joint near the image's edge
 * now projects outside it, out of view. */
static void write_shifted_clip(const char *src, const char *dir, double cx)
{
	char from[4096], to[4200], cwd[2048];
	json_error_t jerr;
	CHECK(getcwd(cwd, sizeof(cwd)) != NULL);
	const char *links[] = {"left", "right", "gt.json"};
	for (int i = 0; i < 3; i++) {
		snprintf(from, sizeof(from), "%s/%s/%s", cwd, src, links[i]);
		snprintf(to, sizeof(to), "%s/%s", dir, links[i]);
		CHECK_MSG(symlink(from, to) == 0, "symlink %s", to);
	}
	snprintf(from, sizeof(from), "%s/calib.json", src);
	json_t *calib = json_load_file(from, 0, &jerr);
	CHECK_MSG(calib && json_is_number(json_object_get(calib, "cx")), "%s:%d: %s", from, jerr.line, jerr.text);
	json_object_set_new(calib, "cx", json_real(cx));
	snprintf(to, sizeof(to), "%s/calib.json", dir);
	CHECK(json_dump_file(calib, to, JSON_INDENT(1)) == 0);
	json_decref(calib);
}

static void remove_shifted_clip(const char *dir)
{
	char path[4200];
	const char *names[] = {"left", "right", "gt.json", "calib.json"};
	for (int i = 0; i < 4; i++) {
		snprintf(path, sizeof(path), "%s/%s", dir, names[i]);
		unlink(path);
	}
	rmdir(dir);
}

int main(int argc, char **argv)
{
	(void)argc;
	mc_test_find_tool(argv[0], "mocap-bench", tool, sizeof(tool));
	if (access("tests/data/ego_demo/gt.json", R_OK) != 0)
		TEST_SKIP("run from the repository root (tests/data/ego_demo not found)");
	/* the bundled clips' limbs move up to a metre: held still, they are lost */
	CHECK(check_limbs_line("tests/data/ego_demo", "", NULL, NULL) >= 3);
	CHECK(check_limbs_line("tests/data/outside_demo", "--cameras 0", NULL, NULL) >= 1);
	double worst_s = -1, view_s = -1;
	char shifted[64];
	snprintf(shifted, sizeof(shifted), "/tmp/mocap-bench-shifted-XXXXXX");
	CHECK(mkdtemp(shifted) != NULL);
	write_shifted_clip("tests/data/ego_demo", shifted, -20);
	CHECK(check_limbs_line(shifted, "", &worst_s, &view_s) >= 3);
	/* the left limbs leave both views, the right ankle for 41 frame sets */
	CHECK_MSG(view_s < worst_s - 0.5, "in view %.2f s, every frame set %.2f s", view_s, worst_s);
	remove_shifted_clip(shifted);
	return mc_test_finish("test_bench_limbs");
}
