/* Tests of core/geom/mc_rig and core/base/mc_json: the rig file format (parse, save,
 * round trip), the shipped rigs, the calib.json, cameras.json and OCamCalib importers, ray
 * tables, and bad input naming the file and the field. */
#include "base/mc_json.h"
#include "geom/mc_rig.h"
#include "test_util.h"

#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define DEG (M_PI / 180.0)

/* Checks that msg contains `expect`. */
#define CHECK_ERR(msg, expect) CHECK_MSG(strstr((msg), (expect)) != NULL, "error '%s' lacks '%s'", (msg), (expect))

/* ---- mc_json ------------------------------------------------------------ */

static void test_json_helpers(void)
{
	mc_err err = {0};
	json_t *root;
	const char *text = "{\"a\": 1.5, \"i\": 256.0, \"s\": \"abc\", \"n\": null, \"b\": true, \"v\": [1, 2, 3],"
			   " \"m\": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]], \"flat\": [1,2,3,4,5,6,7,8,9],"
			   " \"o\": {\"x\": \"str\", \"arr\": [1, \"two\"]}}";
	CHECK(mc_json_load_text(text, "t.json", &root, &err) == 0);
	if (!root)
		return;
	double x = -1;
	int i = -1;
	CHECK(mc_json_number(root, "a", "t.json", &x, true, &err) == 0 && x == 1.5);
	/* absent or null: 1 when optional and *out untouched, -1 when required */
	x = 7;
	CHECK(mc_json_number(root, "zz", "t.json", &x, false, &err) == 1 && x == 7);
	CHECK(mc_json_number(root, "n", "t.json", &x, false, &err) == 1 && x == 7);
	CHECK(mc_json_number(root, "zz", "t.json", &x, true, &err) == -1);
	CHECK(strcmp(err.msg, "t.json: zz: missing") == 0);
	CHECK(mc_json_number(root, "s", "t.json", &x, true, &err) == -1);
	CHECK(strcmp(err.msg, "t.json: s: expected a number, got a string") == 0);
	CHECK(mc_json_positive(root, "a", "t.json", &x, true, &err) == 0);
	CHECK(mc_json_number_range(root, "a", "t.json", 2, 3, &x, true, &err) == -1);
	CHECK_ERR(err.msg, "t.json: a: 1.5 is out of range [2, 3]");
	CHECK(mc_json_int(root, "i", "t.json", 1, 1000, &i, true, &err) == 0 && i == 256);
	CHECK(mc_json_int(root, "a", "t.json", 1, 1000, &i, true, &err) == -1);
	CHECK_ERR(err.msg, "t.json: a: expected an integer, got 1.5");
	CHECK(mc_json_int(root, "i", "t.json", 1, 100, &i, true, &err) == -1);
	CHECK_ERR(err.msg, "out of range");
	bool b = false;
	CHECK(mc_json_bool(root, "b", "t.json", &b, true, &err) == 0 && b);
	char s[4];
	CHECK(mc_json_string(root, "s", "t.json", s, sizeof(s), true, &err) == 0 && strcmp(s, "abc") == 0);
	char s3[3];
	CHECK(mc_json_string(root, "s", "t.json", s3, sizeof(s3), true, &err) == -1);
	CHECK_ERR(err.msg, "t.json: s: string is too long");
	mc_vec3 v;
	CHECK(mc_json_vec3(root, "v", "t.json", &v, true, &err) == 0 && v.z == 3);
	double a4[4];
	CHECK(mc_json_numbers(root, "v", "t.json", a4, 4, true, &err) == -1);
	CHECK_ERR(err.msg, "t.json: v: expected 4 numbers, got 3");
	double m[4][4];
	CHECK(mc_json_mat4(root, "m", "t.json", m, true, &err) == 0 && m[3][3] == 1 && m[0][1] == 0);
	mc_mat3 R;
	CHECK(mc_json_mat3(root, "flat", "t.json", &R, true, &err) == 0 && R.m[1][0] == 4 && R.m[2][2] == 9);
	CHECK(mc_json_mat3(root, "m", "t.json", &R, true, &err) == -1);
	json_t *o, *arr;
	CHECK(mc_json_object(root, "o", "t.json", &o, true, &err) == 0);
	/* a nested path joins with '.' */
	CHECK(mc_json_number(o, "x", "t.json: o", &x, true, &err) == -1);
	CHECK(strcmp(err.msg, "t.json: o.x: expected a number, got a string") == 0);
	double two[2];
	size_t n = 0;
	CHECK(mc_json_numbers_var(o, "arr", "t.json: o", two, 2, &n, true, &err) == -1);
	CHECK(strcmp(err.msg, "t.json: o.arr[1]: expected a number, got a string") == 0);
	CHECK(mc_json_array(root, "v", "t.json", 4, 8, &arr, true, &err) == -1);
	CHECK_ERR(err.msg, "t.json: v: needs at least 4 elements, got 3");
	CHECK(mc_json_array(root, "v", "t.json", 0, 2, &arr, true, &err) == -1);
	CHECK_ERR(err.msg, "at most 2 elements");
	static const char *const keys[] = {"a", "i", "s", "n", "b", "v", "m", "flat", NULL};
	CHECK(mc_json_check_keys(root, "t.json", keys, &err) == -1);
	CHECK(strcmp(err.msg, "t.json: o: unknown field") == 0);
	char p[64];
	CHECK(strcmp(mc_json_path_index(p, sizeof(p), "r.json", "cameras", 2), "r.json: cameras[2]") == 0);
	CHECK(strcmp(mc_json_path(p, sizeof(p), "r.json: cameras[2]", "fx"), "r.json: cameras[2].fx") == 0);
	json_decref(root);

	/* parse errors name line and column; duplicate keys are errors */
	CHECK(mc_json_load_text("{\"a\": 1,\n \"a\": 2}", "d.json", &root, &err) == -1);
	CHECK_ERR(err.msg, "d.json:2:");
	CHECK_ERR(err.msg, "duplicate");
	CHECK(mc_json_load_text("{\"a\": NaN}", "nan.json", &root, &err) == -1);
	CHECK_ERR(err.msg, "nan.json:1:");
	CHECK(mc_json_load_file("tests/data/rigs/does_not_exist.json", &root, &err) == -1);
	CHECK_ERR(err.msg, "tests/data/rigs/does_not_exist.json: ");
}

/* ---- parsing and saving ------------------------------------------------ */

static const char *good_rig =
	"{\"name\": \"lab\", \"kind\": \"outside-in\", \"cameras\": ["
	" {\"name\": \"c0\", \"model\": \"pinhole\", \"width\": 640, \"height\": 480,"
	"  \"fx\": 512.3, \"fy\": 509.8, \"cx\": 321.4, \"cy\": 238.9, \"k\": [-0.281, 0.093, 0.0012, -0.0007, -0.011],"
	"  \"max_theta_deg\": 50,"
	"  \"rig_from_cam\": {\"rotation\": [[0, 0, 1], [0, 1, 0], [-1, 0, 0]], \"translation\": [1, 2, 3]}},"
	" {\"name\": \"c1\", \"model\": \"equidistant\", \"width\": 1280, \"height\": 960,"
	"  \"f\": 331.7, \"cx\": 641.3, \"cy\": 479.2, \"k\": [0.021, -0.0063, 0.0012, -0.00018], \"fov_deg\": 190,"
	"  \"rig_from_cam\": [[1, 0, 0, -1], [0, 1, 0, 0.5], [0, 0, 1, 0], [0, 0, 0, 1]]},"
	" {\"name\": \"c2\", \"model\": \"ocam\", \"width\": 256, \"height\": 256, \"note\": \"a comment\","
	"  \"pol\": [81.5299, 0, -0.0043173, 6.3613e-06, -8.9489e-08], \"invpol\": [128.07, 82.9, 6.2],"
	"  \"xc\": 127.5, \"yc\": 126.5, \"c\": 1.001, \"d\": 0.0005, \"e\": -0.0002, \"max_theta_deg\": 90,"
	"  \"rig_from_cam\": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]}]}";

static void check_same_camera(const mc_camera *a, const mc_camera *b)
{
	CHECK(strcmp(a->name, b->name) == 0);
	CHECK(a->model == b->model && a->width == b->width && a->height == b->height);
	CHECK(a->fx == b->fx && a->fy == b->fy && a->cx == b->cx && a->cy == b->cy);
	CHECK(memcmp(a->k, b->k, sizeof(a->k)) == 0);
	CHECK(a->ocam_pol_len == b->ocam_pol_len && a->ocam_invpol_len == b->ocam_invpol_len);
	CHECK(memcmp(a->ocam_pol, b->ocam_pol, sizeof(a->ocam_pol)) == 0);
	CHECK(memcmp(a->ocam_invpol, b->ocam_invpol, sizeof(a->ocam_invpol)) == 0);
	CHECK(a->ocam_xc == b->ocam_xc && a->ocam_yc == b->ocam_yc);
	CHECK(a->ocam_c == b->ocam_c && a->ocam_d == b->ocam_d && a->ocam_e == b->ocam_e);
	CHECK_NEAR(a->max_theta, b->max_theta, 1e-15);
	CHECK(memcmp(&a->rig_from_cam, &b->rig_from_cam, sizeof(mc_xform)) == 0);
}

static void test_parse_save(void)
{
	mc_rig rig, back;
	mc_err err = {0};
	if (mc_rig_parse(good_rig, "good.json", &rig, &err)) {
		CHECK_MSG(0, "%s", err.msg);
		return;
	}
	CHECK(strcmp(rig.name, "lab") == 0 && rig.kind == MC_RIG_OUTSIDE_IN && rig.ncams == 3);
	const mc_camera *c0 = &rig.cams[0], *c1 = &rig.cams[1], *c2 = &rig.cams[2];
	CHECK(c0->model == MC_CAM_PINHOLE && c0->fx == 512.3 && c0->k[4] == -0.011);
	CHECK_NEAR(c0->max_theta, 50 * DEG, 1e-15);
	CHECK(c0->rig_from_cam.R.m[0][2] == 1 && c0->rig_from_cam.R.m[2][0] == -1 && c0->rig_from_cam.t.z == 3);
	CHECK(c1->model == MC_CAM_EQUIDISTANT && c1->fx == 331.7 && c1->fy == 331.7 && c1->k[3] == -0.00018);
	CHECK_NEAR(c1->max_theta, 95 * DEG, 1e-15);
	CHECK(c1->rig_from_cam.t.x == -1 && c1->rig_from_cam.t.y == 0.5);
	CHECK(c2->model == MC_CAM_OCAM && c2->ocam_pol_len == 5 && c2->ocam_invpol_len == 3);
	CHECK(c2->ocam_yc == 126.5 && c2->ocam_c == 1.001 && c2->ocam_e == -0.0002);
	CHECK(mc_rig_find(&rig, "c1") == 1 && mc_rig_find(&rig, "nope") == -1);

	/* save and load back: the same rig, bit for bit (17 digits) */
	char dir[] = "/tmp/mocap-test-rig-XXXXXX", path[64];
	if (!mkdtemp(dir)) {
		CHECK_MSG(0, "mkdtemp failed");
		return;
	}
	snprintf(path, sizeof(path), "%s/rig.json", dir);
	CHECK(mc_rig_save(&rig, path, &err) == 0);
	if (mc_rig_load(path, &back, &err) == 0) {
		CHECK(strcmp(back.name, rig.name) == 0 && back.kind == rig.kind && back.ncams == rig.ncams);
		for (int i = 0; i < rig.ncams; i++)
			check_same_camera(&rig.cams[i], &back.cams[i]);
	} else {
		CHECK_MSG(0, "%s", err.msg);
	}
	/* as text (what the daemon sends clients): the same rig again */
	char *text = mc_rig_to_json(&rig, &err);
	CHECK(text != NULL);
	if (text && mc_rig_parse(text, "to_json", &back, &err) == 0) {
		CHECK(strcmp(back.name, rig.name) == 0 && back.kind == rig.kind && back.ncams == rig.ncams);
		for (int i = 0; i < rig.ncams; i++)
			check_same_camera(&rig.cams[i], &back.cams[i]);
	} else {
		CHECK_MSG(0, "%s", err.msg);
	}
	free(text);
	/* saving over an unwritable path fails with the path named */
	CHECK(mc_rig_save(&rig, "/nonexistent-dir/rig.json", &err) == -1);
	CHECK_ERR(err.msg, "/nonexistent-dir/rig.json");
	unlink(path);
	rmdir(dir);
}

static void test_shipped_rigs(void)
{
	const char *files[] = {"config/rigs/ego_stereo.json", "config/rigs/ego_stereo_ocam.json"};
	mc_camera_model models[] = {MC_CAM_EQUIDISTANT, MC_CAM_OCAM};
	for (int f = 0; f < 2; f++) {
		mc_rig rig;
		mc_err err = {0};
		if (mc_rig_load(files[f], &rig, &err)) {
			CHECK_MSG(0, "%s", err.msg);
			continue;
		}
		CHECK(rig.kind == MC_RIG_EGOCENTRIC && rig.ncams == 2);
		CHECK(mc_rig_find(&rig, "left") == 0 && mc_rig_find(&rig, "right") == 1);
		for (int i = 0; i < 2; i++) {
			CHECK(rig.cams[i].model == models[f] && rig.cams[i].width == 256 && rig.cams[i].height == 256);
			CHECK_NEAR(rig.cams[i].max_theta, M_PI / 2, 1e-15);
		}
		/* the right camera sits 0.30 m to the right of the left one */
		CHECK_NEAR(rig.cams[1].rig_from_cam.t.x, 0.30, 1e-6);
		CHECK(mc_v3_norm(rig.cams[0].rig_from_cam.t) == 0);
		/* both look along +z over a half-sphere: ahead seen, behind not */
		CHECK(mc_rig_sees(&rig, mc_v3(0.1, 0.5, 1)) && mc_rig_sees(&rig, mc_v3(-2, 0, 0.05)));
		CHECK(!mc_rig_sees(&rig, mc_v3(0.1, 0.5, -1)) && !mc_rig_sees(&rig, mc_v3(-2, 0, -0.05)));
	}
}

/* ---- importers ----------------------------------------------------------- */

static void check_matches(const mc_rig *a, const mc_rig *b, double tol)
{
	CHECK(a->ncams == b->ncams);
	for (int i = 0; i < a->ncams && i < b->ncams; i++) {
		const mc_camera *x = &a->cams[i], *y = &b->cams[i];
		CHECK(strcmp(x->name, y->name) == 0 && x->model == y->model);
		CHECK_NEAR(x->fx, y->fx, tol);
		CHECK_NEAR(x->cx, y->cx, tol);
		CHECK_NEAR(x->ocam_xc, y->ocam_xc, tol);
		for (int k = 0; k < MC_OCAM_POLY_MAX; k++)
			CHECK_NEAR(x->ocam_pol[k], y->ocam_pol[k], tol);
		for (int r = 0; r < 3; r++)
			for (int c = 0; c < 3; c++)
				CHECK_NEAR(x->rig_from_cam.R.m[r][c], y->rig_from_cam.R.m[r][c], tol);
		CHECK(mc_v3_norm(mc_v3_sub(x->rig_from_cam.t, y->rig_from_cam.t)) < tol);
	}
}

static void test_import_ego_calib(void)
{
	const char *data = mc_test_data_dir();
	if (!data) {
		printf("skipped the calib.json import checks: evaluation data not found\n");
		return;
	}
	char path[512];
	snprintf(path, sizeof(path), "%s/ego/walk_131_01/calib.json", data);
	mc_rig rig, orig, shipped;
	mc_err err = {0};
	if (mc_rig_import_ego_calib(path, false, &rig, &err)) {
		CHECK_MSG(0, "%s", err.msg);
		return;
	}
	CHECK(rig.kind == MC_RIG_EGOCENTRIC && rig.ncams == 2);
	CHECK(rig.cams[0].model == MC_CAM_EQUIDISTANT);
	CHECK_NEAR(rig.cams[0].fx, 81.48733086305042, 0);
	CHECK_NEAR(rig.cams[0].max_theta, M_PI / 2, 1e-15);
	/* left = rig frame; the right camera's pose inverts right_from_left */
	CHECK(memcmp(&rig.cams[0].rig_from_cam, &(mc_xform){mc_m3_identity(), mc_v3(0, 0, 0)}, sizeof(mc_xform)) == 0);
	json_t *root;
	double m[4][4];
	CHECK(mc_json_load_file(path, &root, &err) == 0);
	CHECK(mc_json_mat4(root, "right_from_left", path, m, true, &err) == 0);
	json_decref(root);
	mc_xform right_from_left = mc_xform_from_4x4((const double(*)[4])m);
	mc_vec3 p = mc_v3(0.3, -0.7, 1.1);
	mc_vec3 p_right = mc_xform_apply(right_from_left, p);
	/* a point in the right camera's frame maps back to the rig frame */
	CHECK(mc_v3_norm(mc_v3_sub(mc_xform_apply(rig.cams[1].rig_from_cam, p_right), p)) < 1e-6);
	CHECK_NEAR(rig.cams[1].rig_from_cam.t.x, 0.3, 1e-6);
	/* the shipped rigs are this import */
	if (mc_rig_load("config/rigs/ego_stereo.json", &shipped, &err) == 0)
		check_matches(&rig, &shipped, 1e-12);
	orig = rig;
	CHECK(mc_rig_import_ego_calib(path, true, &rig, &err) == 0);
	CHECK(rig.cams[1].model == MC_CAM_OCAM && rig.cams[1].ocam_pol_len == 5);
	CHECK_NEAR(rig.cams[1].ocam_pol[0], 81.52990483414433, 0);
	CHECK(rig.cams[1].ocam_pol[1] == 0);
	CHECK(memcmp(&rig.cams[1].rig_from_cam, &orig.cams[1].rig_from_cam, sizeof(mc_xform)) == 0);
	if (mc_rig_load("config/rigs/ego_stereo_ocam.json", &shipped, &err) == 0)
		check_matches(&rig, &shipped, 1e-12);
	/* the other clip has the same rig */
	snprintf(path, sizeof(path), "%s/ego/jumps_01_01/calib.json", data);
	CHECK(mc_rig_import_ego_calib(path, false, &rig, &err) == 0);
	check_matches(&rig, &orig, 1e-6);
}

/* Writes text to a temporary file; returns its path in buf. */
static const char *temp_file(char *buf, size_t cap, const char *text)
{
	snprintf(buf, cap, "/tmp/mocap-test-rig-XXXXXX");
	int fd = mkstemp(buf);
	if (fd < 0)
		return NULL;
	FILE *f = fdopen(fd, "w");
	fputs(text, f);
	fclose(f);
	return buf;
}

static void test_import_ego_calib_bad(void)
{
	static const char *const cases[][2] = {
		{"{\"width\": 256, \"height\": 256, \"f\": 81.5, \"cx\": 127.5, \"cy\": 127.5, \"fov_deg\": 180}",
		 ": right_from_left: missing"},
		{"{\"width\": 256, \"height\": 256, \"f\": -81.5, \"cx\": 127.5, \"cy\": 127.5, \"fov_deg\": 180}",
		 ": f: must be a positive number"},
		{"{\"width\": 256, \"height\": 256, \"f\": 81.5, \"cx\": 127.5, \"cy\": 127.5, \"fov_deg\": 180,"
		 " \"right_from_left\": [[1,0,0,-0.3],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}",
		 NULL},
		{"{\"width\": 256, \"height\": 256, \"f\": 81.5, \"cx\": 127.5, \"cy\": 127.5, \"fov_deg\": 180,"
		 " \"right_from_left\": [[1,0.3,0,-0.3],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}",
		 ": right_from_left: not a rigid transform"},
		/* Found by the fuzzer: a field of view no rig file may have. */
		{"{\"width\": 256, \"height\": 256, \"f\": 81.5, \"cx\": 127.5, \"cy\": 127.5, \"fov_deg\": 11e-7}",
		 ": fov_deg:"},
	};
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		char path[64];
		mc_rig rig;
		mc_err err = {0};
		if (!temp_file(path, sizeof(path), cases[i][0]))
			continue;
		int r = mc_rig_import_ego_calib(path, false, &rig, &err);
		if (cases[i][1]) {
			CHECK(r == -1);
			CHECK_ERR(err.msg, path);
			CHECK_ERR(err.msg, cases[i][1]);
		} else {
			CHECK_MSG(r == 0, "%s", err.msg);
		}
		/* no ocam_poly: only the ocam import needs it */
		if (!cases[i][1]) {
			CHECK(mc_rig_import_ego_calib(path, true, &rig, &err) == -1);
			CHECK_ERR(err.msg, ": ocam_poly: missing");
		}
		unlink(path);
	}
}

static void test_import_ocamcalib_bad(void)
{
	mc_camera cam;
	mc_err err = {0};
	CHECK(mc_rig_import_ocamcalib("tests/data/ocam/bad_truncated.txt", M_PI / 2, &cam, &err) == -1);
	CHECK(strcmp(err.msg, "tests/data/ocam/bad_truncated.txt: file ends before the inverse polynomial's "
			      "coefficients") == 0);
	CHECK(mc_rig_import_ocamcalib("tests/data/ocam/bad_token.txt", M_PI / 2, &cam, &err) == -1);
	CHECK(strcmp(err.msg, "tests/data/ocam/bad_token.txt:3: '1.9O0000e-03' is not a finite number") == 0);
	CHECK(mc_rig_import_ocamcalib("tests/data/ocam/missing.txt", M_PI / 2, &cam, &err) == -1);
	CHECK_ERR(err.msg, "tests/data/ocam/missing.txt: cannot open");
	static const char *const cases[][2] = {
		{"#c\n\n40 1 2\n", ":3: length of the direct polynomial: expected an integer 1..16, got '40'"},
		{"#c\n\n2.5 1 2\n", ":3: length of the direct polynomial: expected an integer 1..16, got '2.5'"},
		{"2 -80 0\n-1\n", ":2: length of the inverse polynomial: expected an integer 0..32, got '-1'"},
		{"2 -80 0\n0\n127.5 127.5\n1 0 0\n256\n", "file ends before image width"},
		{"2 -80 0\n0\n127.5 127.5\n1 0 0\n256 1e99999\n", ":5: '1e99999' is not a finite number"},
		{"2 -80 0\n0\n127.5 127.5\n1 0 0\n256 nan\n", ":5: 'nan' is not a finite number"},
		{"2 -80 0\n0\n127.5 127.5\n0 0 0\n256 256\n", "affine parameter c must not be 0"},
		/* positive a0: the toolbox's centre pixel would look backwards */
		{"2 80 0\n0\n127.5 127.5\n1 0 0\n256 256\n", ": ocam_pol[0]: must be positive"},
		{"2 -80 0\n0\n127.5 127.5\n1 0 0\n-256 256\n", "image height: expected an integer 1..32768"},
	};
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		char path[64];
		if (!temp_file(path, sizeof(path), cases[i][0]))
			continue;
		CHECK(mc_rig_import_ocamcalib(path, M_PI / 2, &cam, &err) == -1);
		CHECK_ERR(err.msg, path);
		CHECK_ERR(err.msg, cases[i][1]);
		unlink(path);
	}
	/* Not a regular file: refused, not read for ever (issue 20, defect 7). */
	CHECK(mc_rig_import_ocamcalib("/dev/zero", M_PI / 2, &cam, &err) == -1);
	CHECK_ERR(err.msg, "/dev/zero: not a regular file (a character device)");
	CHECK(mc_rig_import_ocamcalib("tests/data/ocam", M_PI / 2, &cam, &err) == -1);
	CHECK_ERR(err.msg, "tests/data/ocam: not a regular file (a directory)");
	/* A line longer than any buffer is one line: the width after 9000
	 * spaces is 256, not cut into 2 and 56 (defect 7). */
	{
		static char text[9200];
		int n = snprintf(text, sizeof(text), "2 -80 0\n0\n127.5 127.5\n1 0 0\n128 %9000s256\n", "");
		char path[64];
		if (n > 0 && temp_file(path, sizeof(path), text)) {
			CHECK_MSG(mc_rig_import_ocamcalib(path, 80 * DEG, &cam, &err) == 0, "%s", err.msg);
			CHECK_MSG(cam.width == 256 && cam.height == 128, "long line: %dx%d", cam.width, cam.height);
			unlink(path);
		}
	}
	/* a minimal valid file: no inverse polynomial, comments anywhere */
	char path[64];
	if (temp_file(path, sizeof(path), "# direct\n2 -80 0\n# inverse\n0\n#centre\n100.5 120.5\n1 0 0\n200 300\n")) {
		CHECK_MSG(mc_rig_import_ocamcalib(path, 80 * DEG, &cam, &err) == 0, "%s", err.msg);
		/* row 100.5 is v, column 120.5 is u */
		CHECK(cam.ocam_xc == 120.5 && cam.ocam_yc == 100.5 && cam.width == 300 && cam.height == 200);
		CHECK(cam.ocam_pol[0] == 80);
		unlink(path);
	}
}

/* ---- bad rig files ------------------------------------------------------ */

/* A good one-camera rig as a jansson object, to be broken by the cases. */
static json_t *good_one_camera(void)
{
	json_error_t je;
	return json_loads("{\"name\": \"r\", \"kind\": \"egocentric\", \"cameras\": [{\"name\": \"left\","
			  " \"model\": \"equidistant\", \"width\": 256, \"height\": 256, \"f\": 81.5, \"cx\": 127.5,"
			  " \"cy\": 127.5, \"k\": [0, 0, 0, 0], \"fov_deg\": 180,"
			  " \"rig_from_cam\": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]}",
			  0, &je);
}

/* Parses `root` dumped as text; expects failure with `expect` in the message. */
static void expect_bad(json_t *root, const char *expect)
{
	char *text = json_dumps(root, JSON_COMPACT);
	mc_rig rig;
	mc_err err = {0};
	CHECK_MSG(mc_rig_parse(text, "bad.json", &rig, &err) == -1, "accepted %s", text);
	CHECK_MSG(strstr(err.msg, expect) != NULL, "for %s: error '%s' lacks '%s'", text, err.msg, expect);
	free(text);
	json_decref(root);
}

/* Sets (or with value NULL deletes) one field of camera 0. */
static void bad_camera_field(const char *key, json_t *value, const char *expect)
{
	json_t *root = good_one_camera();
	json_t *cam = json_array_get(json_object_get(root, "cameras"), 0);
	if (value)
		json_object_set_new(cam, key, value);
	else
		json_object_del(cam, key);
	expect_bad(root, expect);
}

static void bad_top_field(const char *key, json_t *value, const char *expect)
{
	json_t *root = good_one_camera();
	if (value)
		json_object_set_new(root, key, value);
	else
		json_object_del(root, key);
	expect_bad(root, expect);
}

static void test_bad_rigs(void)
{
	mc_rig rig;
	mc_err err = {0};
	/* the base case is good */
	json_t *root = good_one_camera();
	char *text = json_dumps(root, 0);
	CHECK_MSG(mc_rig_parse(text, "good.json", &rig, &err) == 0, "%s", err.msg);
	free(text);
	json_decref(root);

	/* missing fields */
	bad_top_field("name", NULL, "bad.json: name: missing");
	bad_top_field("kind", NULL, "bad.json: kind: missing");
	bad_top_field("cameras", NULL, "bad.json: cameras: missing");
	bad_camera_field("name", NULL, "bad.json: cameras[0].name: missing");
	bad_camera_field("model", NULL, "bad.json: cameras[0].model: missing");
	bad_camera_field("width", NULL, "bad.json: cameras[0].width: missing");
	bad_camera_field("f", NULL, "bad.json: cameras[0].fx: missing");
	bad_camera_field("cy", NULL, "bad.json: cameras[0].cy: missing");
	bad_camera_field("fov_deg", NULL, "bad.json: cameras[0].max_theta_deg: missing (or fov_deg)");
	bad_camera_field("rig_from_cam", NULL, "bad.json: cameras[0].rig_from_cam: missing");
	/* wrong types */
	bad_top_field("name", json_integer(3), "bad.json: name: expected a string, got an integer");
	bad_top_field("cameras", json_object(), "bad.json: cameras: expected an array, got an object");
	bad_camera_field("width", json_string("256"), "bad.json: cameras[0].width: expected an integer, got a string");
	bad_camera_field("width", json_real(255.5), "bad.json: cameras[0].width: expected an integer, got 255.5");
	bad_camera_field("f", json_true(), "bad.json: cameras[0].f: expected a number, got a boolean");
	bad_camera_field("k", json_real(0.1), "bad.json: cameras[0].k: expected an array of 4 numbers");
	bad_camera_field("k", json_pack("[f,f,f]", 0.1, 0.0, 0.0), "bad.json: cameras[0].k: expected 4 numbers, got 3");
	bad_camera_field("k", json_pack("[f,s,f,f]", 0.1, "x", 0.0, 0.0), "bad.json: cameras[0].k[1]: expected a number");
	bad_camera_field("rig_from_cam", json_string("identity"), "bad.json: cameras[0].rig_from_cam: expected a 4x4");
	bad_camera_field("rig_from_cam", json_pack("[[i,i,i,i],[i,i,i,i],[i,i,i,i]]", 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0),
			 "bad.json: cameras[0].rig_from_cam: expected 4 rows of 4 numbers");
	bad_camera_field("rig_from_cam", json_pack("{s:[[i,i,i],[i,i,i],[i,i,i]]}", "rotation", 1, 0, 0, 0, 1, 0, 0, 0, 1),
			 "bad.json: cameras[0].rig_from_cam.translation: missing");
	/* NaN and infinity spelled as strings reach the loader as strings */
	bad_camera_field("cx", json_string("nan"), "bad.json: cameras[0].cx: expected a number, got a string");
	bad_camera_field("f", json_string("inf"), "bad.json: cameras[0].f: expected a number, got a string");
	/* huge but finite numbers: out of range */
	bad_camera_field("f", json_real(1e308), "bad.json: cameras[0].fx: must be in [1, 1e+07] pixels");
	/* absurd but positive: a focal length of 5e-324 pixels, a camera 1e300 m
	 * away (issue 20, defect 8) */
	bad_camera_field("f", json_real(5e-324), "bad.json: cameras[0].fx: must be in [1, 1e+07] pixels, got 4.94066e-324");
	bad_camera_field("rig_from_cam", json_pack("[[i,i,i,f],[i,i,i,i],[i,i,i,i],[i,i,i,i]]", 1, 0, 0, 1e300, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1),
			 "bad.json: cameras[0].rig_from_cam: the camera is 1e+300 m from the rig origin (at most 1000 m)");
	bad_camera_field("cx", json_real(-1e300), "bad.json: cameras[0].cx: must be within +-1e+07 pixels");
	bad_camera_field("fov_deg", json_real(1e300), "bad.json: cameras[0].fov_deg: 1e+300 is out of range");
	/* negative and zero sizes */
	bad_camera_field("height", json_integer(-256), "bad.json: cameras[0].height: -256 is out of range [1, 32768]");
	bad_camera_field("width", json_integer(0), "bad.json: cameras[0].width: 0 is out of range");
	bad_camera_field("f", json_real(-81.5), "bad.json: cameras[0].f: must be a positive number");
	/* unknown model, kind, field */
	bad_camera_field("model", json_string("fisheye"), "bad.json: cameras[0].model: unknown camera model 'fisheye'");
	bad_top_field("kind", json_string("helmet"), "bad.json: kind: unknown rig kind 'helmet'");
	bad_camera_field("fx_", json_real(81.5), "bad.json: cameras[0].fx_: unknown field");
	bad_top_field("camera", json_array(), "bad.json: camera: unknown field");
	bad_camera_field("max_theta_deg", json_real(90), "bad.json: cameras[0].fov_deg: give max_theta_deg or fov_deg, not both");
	bad_camera_field("fx", json_real(81.5), "bad.json: cameras[0].f: give f or fx and fy, not both");
	bad_camera_field("name", json_string(""), "bad.json: cameras[0].name: must not be empty");
	bad_camera_field("name", json_string("a-very-long-camera-name-that-does-not-fit-in-the-sixty-four-bytes-of-the-field"),
			 "bad.json: cameras[0].name: string is too long");
	/* too many or no cameras; duplicate names */
	root = good_one_camera();
	json_t *cams = json_object_get(root, "cameras");
	for (int i = 1; i < MC_MAX_CAMERAS + 1; i++) {
		json_t *c = json_deep_copy(json_array_get(cams, 0));
		char name[16];
		snprintf(name, sizeof(name), "cam%d", i);
		json_object_set_new(c, "name", json_string(name));
		json_array_append_new(cams, c);
	}
	expect_bad(root, "bad.json: cameras: at most 8 elements allowed, got 9");
	bad_top_field("cameras", json_array(), "bad.json: cameras: needs at least 1 element, got 0");
	root = good_one_camera();
	cams = json_object_get(root, "cameras");
	json_array_append_new(cams, json_deep_copy(json_array_get(cams, 0)));
	expect_bad(root, "bad.json: cameras[1].name: camera name 'left' is used twice");
	/* not a rotation, not rigid, a reflection */
	bad_camera_field("rig_from_cam", json_pack("[[f,f,f,f],[i,i,i,i],[i,i,i,i],[i,i,i,i]]", 1.0, 0.2, 0.0, 0.0, 0, 1,
						   0, 0, 0, 0, 1, 0, 0, 0, 0, 1),
			 "bad.json: cameras[0].rig_from_cam: rotation block is not a rotation");
	bad_camera_field("rig_from_cam", json_pack("[[i,i,i,i],[i,i,i,i],[i,i,i,i],[i,i,i,i]]", 1, 0, 0, 0, 0, 1, 0, 0,
						   0, 0, 1, 0, 0, 0, 1, 1),
			 "bad.json: cameras[0].rig_from_cam[3]: last row of a rigid transform must be [0, 0, 0, 1]");
	bad_camera_field("rig_from_cam", json_pack("{s:[[i,i,i],[i,i,i],[i,i,i]],s:[i,i,i]}", "rotation", -1, 0, 0, 0,
						   1, 0, 0, 0, 1, "translation", 0, 0, 0),
			 "bad.json: cameras[0].rig_from_cam: rotation block is not a rotation");
	/* model-specific: folding distortion, ocam without pol */
	bad_camera_field("k", json_pack("[f,f,f,f]", -0.5, 0.0, 0.0, 0.0), "bad.json: cameras[0].k: distortion folds back");
	root = good_one_camera();
	json_t *cam = json_array_get(json_object_get(root, "cameras"), 0);
	json_object_set_new(cam, "model", json_string("ocam"));
	json_object_del(cam, "f");
	json_object_del(cam, "k");
	json_object_del(cam, "cx");
	json_object_del(cam, "cy");
	json_object_set_new(cam, "xc", json_real(127.5));
	json_object_set_new(cam, "yc", json_real(127.5));
	expect_bad(json_deep_copy(root), "bad.json: cameras[0].pol: missing");
	json_object_set_new(cam, "pol", json_pack("[f,f,f]", 81.5, 0.0, -0.004));
	json_object_set_new(cam, "c", json_real(0));
	expect_bad(json_deep_copy(root), "bad.json: cameras[0].ocam_c: affine matrix [c d; e 1] must have a positive");
	json_object_set_new(cam, "c", json_real(1));
	json_object_set_new(cam, "f", json_real(81.5)); /* pinhole fields are unknown to ocam */
	expect_bad(root, "bad.json: cameras[0].f: unknown field");
	/* top level */
	CHECK(mc_rig_parse("[1, 2]", "bad.json", &rig, &err) == -1);
	CHECK_ERR(err.msg, "bad.json: expected a JSON object at the top level");
	CHECK(mc_rig_parse("{\"name\": \"a\", \"name\": \"b\"}", "bad.json", &rig, &err) == -1);
	CHECK_ERR(err.msg, "bad.json:1:");
	CHECK_ERR(err.msg, "duplicate object key");

	/* files: the file name, line and column appear in the message */
	CHECK(mc_rig_load("tests/data/rigs/syntax_error.json", &rig, &err) == -1);
	CHECK_ERR(err.msg, "tests/data/rigs/syntax_error.json:4:");
	/* jansson refuses 1e999 itself, at its line */
	CHECK(mc_rig_load("tests/data/rigs/overflow.json", &rig, &err) == -1);
	CHECK_ERR(err.msg, "tests/data/rigs/overflow.json:6:15:");
	CHECK_ERR(err.msg, "real number overflow");
	CHECK(mc_rig_load("tests/data/rigs/nan_string.json", &rig, &err) == -1);
	CHECK(strcmp(err.msg, "tests/data/rigs/nan_string.json: cameras[0].cx: expected a number, got a string") == 0);
	CHECK(mc_rig_load("tests/data/rigs/not_rotation.json", &rig, &err) == -1);
	CHECK_ERR(err.msg, "tests/data/rigs/not_rotation.json: cameras[0].rig_from_cam: rotation block is not a rotation");
	CHECK(mc_rig_load("tests/data/rigs/missing.json", &rig, &err) == -1);
	CHECK_ERR(err.msg, "tests/data/rigs/missing.json: ");
}

/* ---- ray tables ------------------------------------------------------------ */

static void test_raytables(void)
{
	mc_rig rig;
	mc_err err = {0};
	if (mc_rig_load("config/rigs/ego_stereo.json", &rig, &err)) {
		CHECK_MSG(0, "%s", err.msg);
		return;
	}
	/* rotate the right camera by 30 degrees about y to see rotations act */
	mc_camera right = rig.cams[1];
	right.rig_from_cam.R = mc_m3_rot_axis(1, 30 * DEG);
	mc_raytable left_rt, right_rt, full;
	CHECK(mc_raytable_build(&rig.cams[0], 128, 128, &left_rt, &err) == 0);
	CHECK(mc_raytable_build(&right, 128, 128, &right_rt, &err) == 0);
	CHECK(mc_raytable_build(&rig.cams[0], 256, 256, &full, &err) == 0);
	if (!left_rt.dir || !right_rt.dir || !full.dir)
		goto out;
	CHECK(left_rt.scale_x == 2 && left_rt.scale_y == 2);
	/* origins: the camera centres in the rig frame */
	CHECK(mc_v3_norm(left_rt.origin) == 0);
	CHECK_NEAR(right_rt.origin.x, 0.30, 1e-6);
	/* the image circle spans the width: valid ~ pi/4 of the square */
	double frac = (double)left_rt.nvalid / (128 * 128);
	printf("ray table 128x128: %d valid (%.4f of the image, pi/4 = %.4f)\n", left_rt.nvalid, frac, M_PI / 4);
	CHECK(fabs(frac - M_PI / 4) < 0.01);
	int counted = 0;
	double worst_unit = 0, worst_rot = 0;
	mc_mat3 R = right.rig_from_cam.R;
	for (int k = 0; k < 128 * 128; k++) {
		counted += left_rt.valid[k];
		CHECK(left_rt.valid[k] == right_rt.valid[k]);
		if (!left_rt.valid[k]) {
			CHECK(mc_v3_norm(left_rt.dir[k]) == 0);
			continue;
		}
		worst_unit = fmax(worst_unit, fabs(mc_v3_norm(left_rt.dir[k]) - 1));
		/* same lens: right rays are the left rays rotated by R */
		worst_rot = fmax(worst_rot, mc_v3_norm(mc_v3_sub(right_rt.dir[k], mc_m3_apply(R, left_rt.dir[k]))));
	}
	CHECK(counted == left_rt.nvalid);
	CHECK(worst_unit < 1e-12);
	CHECK(worst_rot < 1e-12);
	/* working pixel (i, j) samples native ((i + 0.5) * 2 - 0.5, ...): pixel
	 * (63, 63) looks at native (126.5, 126.5), one pixel from the axis */
	mc_vec3 d = left_rt.dir[63 * 128 + 63];
	CHECK_NEAR(atan2(hypot(d.x, d.y), d.z), hypot(1, 1) / 81.48733086305042, 1e-12);
	CHECK(d.x < 0 && d.y < 0);
	/* the right camera's centre ray points along R's z column */
	mc_vec3 dr = right_rt.dir[63 * 128 + 63], zc = mc_v3(R.m[0][2], R.m[1][2], R.m[2][2]);
	CHECK(acos(fmin(1, mc_v3_dot(dr, zc))) < 0.02);
	/* at native resolution the table is the camera's own unprojection */
	for (int j = 0; j < 256; j += 17)
		for (int i = 0; i < 256; i += 13) {
			mc_vec3 ray;
			bool ok = mc_camera_unproject(&rig.cams[0], i, j, &ray);
			CHECK(ok == (full.valid[j * 256 + i] == 1));
			if (ok)
				CHECK(mc_v3_norm(mc_v3_sub(ray, full.dir[j * 256 + i])) < 1e-15);
		}
	/* bad sizes */
	mc_raytable bad;
	CHECK(mc_raytable_build(&rig.cams[0], 0, 128, &bad, &err) == -1);
	CHECK_ERR(err.msg, "camera 'left': ray table size 0x128 out of range");
	CHECK(bad.dir == NULL && bad.valid == NULL);
	mc_camera broken = rig.cams[0];
	broken.fx = -1;
	CHECK(mc_raytable_build(&broken, 64, 64, &bad, &err) == -1);
	CHECK_ERR(err.msg, "camera 'left': fx: must be in [1");
	/* a camera whose every pixel lies outside its field of view has no
	 * ray: refused, not tracked with nothing (issue 20, defect 8) */
	broken = rig.cams[0];
	broken.cx = broken.cy = -1e6;
	broken.max_theta = 0.1;
	CHECK(mc_raytable_build(&broken, 64, 64, &bad, &err) == -1);
	CHECK_ERR(err.msg, "camera 'left': no pixel has a ray");
	CHECK(bad.dir == NULL && bad.valid == NULL);
out:
	mc_raytable_free(&left_rt);
	mc_raytable_free(&right_rt);
	mc_raytable_free(&full);
	mc_raytable_free(&full); /* freeing twice is harmless */
}

/* ---- outside-in cameras.json -------------------------------------------- */

/* tests/data/outside holds one set of cameras in both formats
 * (make_fixtures.py): the import must equal the rig file, and project
 * world points as OpenCV's formula does. */
static void test_import_cameras_json(void)
{
	mc_rig imported, rig;
	mc_err err = {0};
	CHECK_MSG(mc_rig_import_cameras_json("tests/data/outside/cameras.json", &imported, &err) == 0, "%s", err.msg);
	CHECK_MSG(mc_rig_load("tests/data/outside/rig.json", &rig, &err) == 0, "%s", err.msg);
	CHECK(imported.kind == MC_RIG_OUTSIDE_IN && imported.ncams == 4);
	for (int c = 0; c < imported.ncams && c < rig.ncams; c++) {
		const mc_camera *a = &imported.cams[c], *b = &rig.cams[c];
		CHECK(strcmp(a->name, b->name) == 0 && a->model == MC_CAM_PINHOLE);
		CHECK(a->width == 320 && a->height == 240 && a->fx == 280 && a->cy == 119.5);
		for (int i = 0; i < 5; i++)
			CHECK(a->k[i] == b->k[i]);
		CHECK(mc_v3_norm(mc_v3_sub(a->rig_from_cam.t, b->rig_from_cam.t)) < 1e-9);
		/* every image corner has a ray: the field of view covers the image */
		double corner = atan(hypot(160.0 / 280, 120.0 / 280));
		CHECK(a->max_theta > corner && a->max_theta < 89 * DEG);
		/* a world point projects where x = fx X / Z + cx says (no distortion on cam0) */
		mc_vec3 world = mc_v3(0.3, -0.2, 1.1);
		mc_vec3 pa = mc_xform_apply(mc_xform_inverse(a->rig_from_cam), world);
		mc_vec3 pb = mc_xform_apply(mc_xform_inverse(b->rig_from_cam), world);
		double ua, va, ub, vb;
		CHECK(mc_camera_project(a, pa, &ua, &va) && mc_camera_project(b, pb, &ub, &vb));
		CHECK_MSG(fabs(ua - ub) < 1e-6 && fabs(va - vb) < 1e-6, "cam%d: %g,%g vs %g,%g", c, ua, va, ub, vb);
		if (c == 0)
			CHECK(fabs(ua - (280 * pa.x / pa.z + 159.5)) < 1e-9 && fabs(va - (280 * pa.y / pa.z + 119.5)) < 1e-9);
	}
}

static void test_import_cameras_json_bad(void)
{
	static const char *const cam =
		"\"width\": 320, \"height\": 240, \"fx\": 280, \"fy\": 280, \"cx\": 159.5, \"cy\": 119.5,"
		" \"world_to_camera\": [[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]";
	char text[5][1024];
	snprintf(text[0], sizeof(text[0]), "{\"cameras\": [{\"name\": \"a\", \"model\": \"fisheye\", %s}]}", cam);
	snprintf(text[1], sizeof(text[1]),
		 "{\"cameras\": [{\"name\": \"a\", \"model\": \"pinhole\", %s}, {\"name\": \"a\", \"model\": \"pinhole\", %s}]}",
		 cam, cam);
	snprintf(text[2], sizeof(text[2]),
		 "{\"cameras\": [{\"name\": \"a\", \"model\": \"pinhole\", \"dist\": [0, 0, 0], %s}]}", cam);
	snprintf(text[3], sizeof(text[3]), "{\"cameras\": [{\"name\": \"a\", \"model\": \"pinhole\", \"fx\": 280}]}");
	/* Found by the fuzzer: an unnamed camera, which no rig file may have. */
	snprintf(text[4], sizeof(text[4]), "{\"cameras\": [{\"name\": \"\", \"model\": \"pinhole\", %s}]}", cam);
	const char *const expect[][2] = {
		{"cameras[0].model", "only 'pinhole'"},
		{"cameras[1].name", "used twice"},
		{"cameras[0].dist", "expected 4 or 5 numbers"},
		{"cameras[0]", "missing"},
		{"cameras[0].name", "must not be empty"},
	};
	for (int i = 0; i < 5; i++) {
		char path[64];
		mc_rig rig;
		mc_err err = {0};
		if (!temp_file(path, sizeof(path), text[i]))
			continue;
		CHECK(mc_rig_import_cameras_json(path, &rig, &err) == -1);
		CHECK_ERR(err.msg, path);
		CHECK_ERR(err.msg, expect[i][0]);
		CHECK_ERR(err.msg, expect[i][1]);
		unlink(path);
	}
}

int main(void)
{
	test_json_helpers();
	test_parse_save();
	test_shipped_rigs();
	test_import_ego_calib();
	test_import_ego_calib_bad();
	test_import_ocamcalib_bad();
	test_import_cameras_json();
	test_import_cameras_json_bad();
	test_bad_rigs();
	test_raytables();
	return mc_test_finish("test_rig");
}
