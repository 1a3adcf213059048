/* Tests of the motion graphs on the CMU clips in ../shared/data (skipped
 * with 77 when absent), at 10 fps to stay quick:
 *   - Boukhayma fig. 9: the Essential graph's shortest paths cost less on
 *     average than the motion graph's, at each alpha;
 *   - a 10-minute walk: transitions no rougher than the recorded clips, no
 *     joint below the floor, bone lengths kept;
 *   - mocap-train: three skeleton namings in one database, a parametric
 *     walk node, steering to a class;
 *   - the command lines scripts rely on. */
#include "body/mc_bvh.h"
#include "motion/mc_motion_param.h"
#include "motion/mc_motion_synth.h"
#include "motion_fixture.h"
#include "test_util.h"

static char graph_bin[4200]; /* BUILD/bin/mocap-graph, beside this test's BUILD */

#define J MC_MOTION_JOINTS
#define FPS 10.0

static char data[512];

static void add(mc_motion_db *db, const char *rel, const char *cls)
{
	char path[1024];
	mc_err err;
	snprintf(path, sizeof(path), "%s/%s", data, rel);
	CHECK_MSG(mc_motion_db_add_bvh(db, path, cls, &err) == 0, "%s", err.msg);
}

static void test_fig9(const mc_motion_db *db, const mc_cost_matrix *m, int lmax)
{
	const int n = db->nframes;
	uint8_t *keep = malloc((size_t)n * n);
	mc_err err;
	const double alphas[] = {1e-4, 1e-3, 1e-2};
	for (int i = 0; i < 3; i++) {
		mc_graph_stats e, g;
		CHECK(mc_graph_essential(db, m, lmax, alphas[i], 0, keep, &e, &err) == 0);
		mc_graph_motion(db, m, lmax, keep);
		CHECK(mc_graph_stats_of(db, m, alphas[i], keep, 0, &g, &err) == 0);
		printf("alpha %g: Essential mean %.4f var %.5f density %.2e | motion graph mean %.4f var %.5f density %.2e\n",
		       alphas[i], e.mean, e.var, e.density, g.mean, g.var, g.density);
		CHECK_MSG(e.mean < g.mean, "alpha %g: Essential %g, motion graph %g", alphas[i], e.mean, g.mean);
		CHECK(e.var < g.var);
		CHECK(e.unreachable <= g.unreachable + 1e-12);
		/* density grows with alpha */
		static double last;
		if (i > 0)
			CHECK(e.density > last);
		last = e.density;
	}
	free(keep);
}

static void test_long_walk(const mc_motion_graph *g)
{
	mc_err err;
	mc_walker *w = mc_walker_new(g, MC_EDGE_ESSENTIAL, 11, &err);
	CHECK_MSG(w, "%s", err.msg);
	if (!w)
		return;
	int n = (int)(600 * g->db.fps);
	mc_vec3(*p)[J] = malloc(sizeof(*p) * (size_t)n);
	uint8_t *syn = malloc((size_t)n);
	for (int k = 0; k < n; k++)
		syn[k] = (uint8_t)mc_walker_next(w, p[k]);
	double clip_v, clip_a, tv = 0, ta = 0, zmin = INFINITY, bone = 0;
	mc_motion_db_jumps(&g->db, &clip_v, &clip_a);
	for (int k = 0; k + 3 < n; k++) {
		if (syn[k] || syn[k + 1] || syn[k + 2])
			tv = fmax(tv, mc_pose_vel_jump(p[k], p[k + 1], p[k + 2], g->db.fps));
		if (syn[k] || syn[k + 1] || syn[k + 2] || syn[k + 3])
			ta = fmax(ta, mc_pose_acc_jump(p[k], p[k + 1], p[k + 2], p[k + 3], g->db.fps));
	}
	for (int k = 0; k < n; k++)
		for (int j = 0; j < J; j++) {
			zmin = fmin(zmin, p[k][j].z);
			if (j > 0)
				bone = fmax(bone, fabs(mc_v3_norm(mc_v3_sub(p[k][j], p[k][g->db.skel.parent[j]])) -
						       mc_v3_norm(g->db.skel.offset[j])));
		}
	printf("10-minute walk: %ld transitions; velocity jump %.2f m/s at transitions, %.2f in the clips; "
	       "acceleration jump %.0f / %.0f m/s2; lowest joint %.4f m; bone error %.1e m\n",
	       mc_walker_transitions(w), tv, clip_v, ta, clip_a, zmin, bone);
	CHECK(mc_walker_transitions(w) > 20);
	CHECK_MSG(tv <= clip_v * (1 + 1e-9), "a transition jumps by %g m/s, the clips by %g at most", tv, clip_v);
	CHECK(zmin >= -1e-9);
	CHECK(bone < 1e-6);
	free(p);
	free(syn);
	mc_walker_free(w);
}

static void test_train(void)
{
	char probe[1024];
	snprintf(probe, sizeof(probe), "%s/mocap-train/cmu_daz/05_01.bvh", data);
	if (access(probe, R_OK) != 0) {
		printf("no mocap-train: its part skipped\n");
		return;
	}
	mc_motion_db db;
	mc_motion_db_init(&db, FPS, NULL);
	add(&db, "mocap-train/cmu_mb/02_01.bvh", "walk");
	add(&db, "mocap-train/cmu_daz/05_01.bvh", "walk");
	add(&db, "mocap-train/cmu_daz/07_03.bvh", "walk");
	add(&db, "mocap-train/cmu_daz/16_36.bvh", "run");
	mc_err err;
	char bad[1024];
	snprintf(bad, sizeof(bad), "%s/mocap-train/cmu_iclone/03_01.bvh", data);
	CHECK(mc_motion_db_add_bvh(&db, bad, "", &err) == -1 && strstr(err.msg, "03_01.bvh") && strstr(err.msg, "no joint"));
	CHECK(db.nclips == 4);
	mc_cost_params p;
	mc_cost_params_default(&p, db.fps);
	mc_cost_matrix m;
	CHECK_MSG(mc_cost_matrix_build(&db, &p, &m, &err) == 0, "%s", err.msg);
	mc_motion_graph g;
	CHECK_MSG(mc_graph_build(&db, &m, &p, 1e-4, &g, NULL, &err) == 0, "%s", err.msg);
	mc_cost_matrix_free(&m);
	CHECK_MSG(g.nparams == 1 && g.params[0].nmembers == 3, "parametric nodes %d", g.nparams);
	if (g.nparams == 1) {
		float lo = INFINITY, hi = 0;
		for (int i = 0; i < 3; i++) {
			printf("walk member %s: %.2f m/s, %.1f deg/s\n", g.db.clips[g.params[0].clip[i]].name,
			       g.params[0].speed[i], g.params[0].turn[i]);
			lo = fminf(lo, g.params[0].speed[i]);
			hi = fmaxf(hi, g.params[0].speed[i]);
		}
		CHECK(lo > 0.3 && hi < 2.5);
		/* Casas: a walk at a speed between the members' */
		double target = (lo + hi) / 2;
		mc_param_motion pm;
		CHECK_MSG(mc_param_blend(&g, 0, target, &pm, &err) == 0, "%s", err.msg);
		printf("walk blended to %.2f m/s: %s and %s, weight %.2f, %.3f m/s over %d frames\n", target,
		       g.db.clips[pm.clip_a].name, g.db.clips[pm.clip_b].name, pm.w, pm.speed, pm.nframes);
		CHECK_MSG(fabs(pm.speed - target) < 0.05 * target, "%g m/s for %g", pm.speed, target);
		free(pm.poses);
	}
	mc_walker *w = mc_walker_new(&g, MC_EDGE_ESSENTIAL, 5, &err);
	CHECK_MSG(w, "%s", err.msg);
	mc_steer s = {.kind = MC_STEER_CLASS, .speed = -1};
	snprintf(s.cls, sizeof(s.cls), "run");
	int reached = -1;
	if (w && mc_walker_steer(w, &s, &err) == 0) {
		mc_vec3 pose[J];
		for (int k = 0; k < 60 * FPS && reached < 0; k++) {
			mc_walker_next(w, pose);
			if (strcmp(g.db.clips[g.db.clip_of[mc_walker_node(w)]].cls, "run") == 0)
				reached = k;
		}
	}
	printf("steered to 'run' in %.1f s\n", reached / FPS);
	CHECK(reached >= 0);
	mc_walker_free(w);
	mc_graph_free(&g);
}

static void test_command_lines(void)
{
	char dir[] = "/tmp/test_motion_data.XXXXXX";
	if (!mkdtemp(dir))
		return;
	char cmd[16384], out[8192];
	snprintf(cmd, sizeof(cmd),
		 "%s build --fps 10 --out %s/g.mg %s/mocap/131_01.bvh %s/mocap/01_01.bvh 2>&1", graph_bin, dir,
		 data, data);
	int rc = mc_test_run(cmd, out, sizeof(out));
	CHECK_MSG(rc == 0 && strstr(out, "costs 100%"), "%s: %d %s", cmd, rc, out);
	snprintf(cmd, sizeof(cmd), "%s walk %s/g.mg --seconds 12 --bvh %s/w.bvh --seed 4 --rate 30 2>&1", graph_bin,
		 dir, dir);
	rc = mc_test_run(cmd, out, sizeof(out));
	CHECK_MSG(rc == 0, "%s: %d %s", cmd, rc, out);
	char path[600];
	snprintf(path, sizeof(path), "%s/w.bvh", dir);
	mc_bvh b;
	mc_err err;
	CHECK_MSG(mc_bvh_load(path, &b, &err) == 0, "%s", err.msg);
	CHECK(b.nframes == 360 && fabs(b.frame_time - 1 / 30.0) < 1e-6 && mc_bvh_find(&b, "left_toe") >= 0);
	if (b.nframes == 360)
		mc_bvh_free(&b);
	snprintf(cmd, sizeof(cmd), "%s check %s/g.mg --seconds 600 --seed 3 2>&1", graph_bin, dir);
	rc = mc_test_run(cmd, out, sizeof(out));
	printf("%s", out);
	CHECK_MSG(rc == 0 && strstr(out, "continuous"), "%s: %d", cmd, rc);
	snprintf(cmd, sizeof(cmd), "rm -rf %s", dir);
	if (system(cmd) != 0)
		printf("could not remove %s\n", dir);
}

int main(void)
{
	find_graph_bin(graph_bin, sizeof(graph_bin));
	const char *d = mc_test_data_dir();
	if (!d)
		return 77;
	snprintf(data, sizeof(data), "%s", d);
	char probe[600];
	snprintf(probe, sizeof(probe), "%s/mocap/131_01.bvh", data);
	if (access(probe, R_OK) != 0) {
		printf("%s missing: skipped\n", probe);
		return 77;
	}
	mc_motion_db db;
	mc_motion_db_init(&db, FPS, NULL);
	add(&db, "mocap/131_01.bvh", "walk");
	add(&db, "mocap/01_01.bvh", "jumps");
	mc_cost_params p;
	mc_cost_params_default(&p, db.fps);
	mc_cost_matrix m;
	mc_err err;
	CHECK_MSG(mc_cost_matrix_build(&db, &p, &m, &err) == 0, "%s", err.msg);
	test_fig9(&db, &m, p.lmax);
	mc_motion_graph g;
	CHECK_MSG(mc_graph_build(&db, &m, &p, 1e-4, &g, NULL, &err) == 0, "%s", err.msg);
	mc_cost_matrix_free(&m);
	test_long_walk(&g);
	mc_graph_free(&g);
	test_train();
	test_command_lines();
	return mc_test_failures ? 1 : 0;
}
