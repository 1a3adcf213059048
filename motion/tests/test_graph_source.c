/* mocapd's graph source ([source] graph, docs/MOTION_GRAPH.md) end to end:
 * a graph of synthetic BVH clips (no shared data), mocapd streaming its
 * walk through the socket (skeleton definition, continuous frames above the
 * floor), STEER control requests good and bad (the daemon answers and keeps
 * streaming), requests it cannot serve refused, a bad graph file and a
 * config with cameras refused with the file and key named, SIGTERM. */
#include "daemon/harness.h"
#include "mocap.h"
#include "motion/mc_motion_synth.h"
#include "motion_fixture.h"

#define J MC_MOTION_JOINTS

static void make_graph(const char *dir, char *graph, size_t cap)
{
	char a[300], c[300];
	snprintf(a, sizeof(a), "%s/straight.bvh", dir);
	snprintf(c, sizeof(c), "%s/turn.bvh", dir);
	snprintf(graph, cap, "%s/g.mg", dir);
	CHECK(fixture_write(a, 6, 60, 1.0, 120, 0) == 0);
	CHECK(fixture_write(c, 6, 60, 1.0, 110, 40) == 0);
	mc_motion_db db;
	mc_err err;
	mc_motion_db_init(&db, 15, NULL);
	CHECK_MSG(mc_motion_db_add_bvh(&db, a, "walk", &err) == 0, "%s", err.msg);
	CHECK_MSG(mc_motion_db_add_bvh(&db, c, "turn", &err) == 0, "%s", err.msg);
	mc_cost_params p;
	mc_cost_params_default(&p, db.fps);
	mc_cost_matrix m;
	CHECK_MSG(mc_cost_matrix_build(&db, &p, &m, &err) == 0, "%s", err.msg);
	mc_motion_graph g;
	CHECK_MSG(mc_graph_build(&db, &m, &p, 1e-3, &g, NULL, &err) == 0, "%s", err.msg);
	CHECK_MSG(mc_graph_save(&g, graph, &err) == 0, "%s", err.msg);
	mc_cost_matrix_free(&m);
	mc_graph_free(&g);
}

/* Frames for ms milliseconds: how many, the largest joint speed between
 * consecutive ones (step over the capture times: the poses are those of
 * their timestamps, so a late frame on a busy machine is no jump) and the
 * lowest joint. */
static int read_frames(mocap_client *c, int ms, double *step, double *zmin)
{
	static mocap_skeleton_frame f, prev;
	int n = 0;
	uint64_t end = mcd_now_ms() + (uint64_t)ms;
	while (mcd_now_ms() < end) {
		if (mocap_read_frame(c, &f, 50) != 1)
			continue;
		for (int j = 0; j < f.njoints; j++) {
			*zmin = fmin(*zmin, f.joints[j].position[2]);
			if (n > 0 && f.seq == prev.seq + 1) {
				double d = 0;
				for (int k = 0; k < 3; k++)
					d += pow(f.joints[j].position[k] - prev.joints[j].position[k], 2);
				double dt = (double)(f.capture_ns - prev.capture_ns) * 1e-9;
				if (dt > 0)
					*step = fmax(*step, sqrt(d) / dt);
			}
		}
		prev = f;
		n++;
	}
	return n;
}

/* Rotates v by the unit quaternion q (w, x, y, z). */
static void quat_rotate(const double q[4], const double v[3], double out[3])
{
	double w = q[0], x = q[1], y = q[2], z = q[3];
	double t[3] = {2 * (y * v[2] - z * v[1]), 2 * (z * v[0] - x * v[2]), 2 * (x * v[1] - y * v[0])};
	out[0] = v[0] + w * t[0] + (y * t[2] - z * t[1]);
	out[1] = v[1] + w * t[1] + (z * t[0] - x * t[2]);
	out[2] = v[2] + w * t[2] + (x * t[1] - y * t[0]);
}

/* The largest distance, over n frames, between a joint and where its
 * definition puts it: the parent's position plus the rest offset turned
 * by the parent's orientation (docs/PROTOCOL.md, SKELETON).  Clients that
 * drive a rig by local rotations (VMC) depend on this. */
static double definition_error(mocap_client *c, const mocap_skeleton_def *def, int n, int *worst)
{
	static mocap_skeleton_frame f;
	double err = 0;
	for (int k = 0; k < n; k++) {
		if (mocap_read_frame(c, &f, 1000) != 1)
			return INFINITY;
		for (int j = 1; j < f.njoints; j++) {
			int p = def->joints[j].parent;
			double r[3];
			quat_rotate(f.joints[p].orientation, def->joints[j].rest_offset, r);
			double d = 0;
			for (int i = 0; i < 3; i++)
				d += pow(f.joints[p].position[i] + r[i] - f.joints[j].position[i], 2);
			if (sqrt(d) > err) {
				err = sqrt(d);
				*worst = j;
			}
		}
	}
	return err;
}

static int control(mocap_client *c, const char *arg, char *msg, size_t cap)
{
	msg[0] = 0;
	return mocap_control(c, MOCAP_CMD_STEER, arg, msg, cap);
}

static void test_stream(mcd_run *r)
{
	mocap_client *c = mocap_connect(r->sock, "test_graph_source");
	CHECK(c != NULL);
	if (!c)
		return;
	static mocap_skeleton_def def;
	CHECK(mocap_get_skeleton(c, &def) == 0);
	CHECK(def.njoints == J && def.rig_is_world && strcmp(def.joints[0].name, "pelvis") == 0 &&
	      strcmp(def.joints[MC_MJ_RTOE].name, "right_toe") == 0 && def.joints[MC_MJ_RTOE].parent == MC_MJ_RANKLE);
	CHECK(mocap_subscribe(c, MOCAP_ALL, MOCAP_SPACE_RIG, 0) == 0);
	double step = 0, zmin = INFINITY;
	int n = read_frames(c, 1500, &step, &zmin);
	printf("%d frames in 1.5 s at 100 Hz, fastest joint %.2f m/s, lowest joint %.4f m\n", n, step, zmin);
	CHECK_MSG(n >= 100, "%d frames in 1.5 s", n);
	CHECK_MSG(step < 10, "a joint moved at %.2f m/s between two frames", step);
	CHECK(zmin >= -1e-6);
	int worst = 0;
	double derr = definition_error(c, &def, 100, &worst);
	printf("graph skeletons against their definition: worst %.3g m (%s)\n", derr, def.joints[worst].name);
	CHECK_MSG(derr < 1e-9, "a joint is %.3g m from where its definition puts it (%s)", derr, def.joints[worst].name);

	char msg[1024];
	/* what may be steered to: the classes and frames of the walk's component */
	int rc = control(c, "list", msg, sizeof(msg));
	printf("steer list: %s\n", msg);
	CHECK_MSG(rc == 0 && strstr(msg, "classes: walk, turn") && strstr(msg, "frames: ") && strstr(msg, "+x"),
		  "steer list: %d '%s'", rc, msg);
	rc = control(c, "class turn", msg, sizeof(msg));
	CHECK_MSG(rc == 0 && strstr(msg, "class turn"), "%d '%s'", rc, msg);
	rc = control(c, "direction -90 speed 1.2", msg, sizeof(msg));
	CHECK_MSG(rc == 0, "%d '%s'", rc, msg);
	rc = control(c, "speed 1.5", msg, sizeof(msg));
	CHECK_MSG(rc == 0, "%d '%s'", rc, msg);
	const struct {
		const char *arg, *want;
	} bad[] = {
		{"class dance", "dance"},     {"frame 99999", "99999"},        {"frame -3", "frame"},
		{"direction north", "north"}, {"direction 0 speed 99", "speed"}, {"speed fast", "fast"},
		{"jump", "not a target"},
		{"", "not a target"},
	};
	for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
		rc = control(c, bad[i].arg, msg, sizeof(msg));
		CHECK_MSG(rc == MOCAP_E_FAILED && strstr(msg, bad[i].want), "'%s': %d '%s'", bad[i].arg, rc, msg);
	}
	rc = mocap_control(c, MOCAP_CMD_RECORD_START, "", msg, sizeof(msg));
	CHECK_MSG(rc == MOCAP_E_FAILED && strstr(msg, "[source] graph"), "record start: %d '%s'", rc, msg);
	rc = mocap_control(c, MOCAP_CMD_ACTOR_SAVE, "a", msg, sizeof(msg));
	CHECK(rc == MOCAP_E_FAILED);
	rc = control(c, "none", msg, sizeof(msg));
	CHECK(rc == 0);
	/* still streaming, still continuous */
	step = 0;
	n = read_frames(c, 1000, &step, &zmin);
	CHECK_MSG(n >= 60 && step < 10 && zmin >= -1e-6, "after the requests: %d frames, %g m/s, lowest %g", n, step,
		  zmin);
	mocap_daemon_status st;
	CHECK(mocap_get_status(c, &st) == 0);
	mocap_close(c);
}

int main(void)
{
	if (!mcd_find_build_up(3))
		TEST_SKIP("mocapd is not built");
	mcd_run r;
	if (!mcd_run_init(&r)) {
		printf("cannot make a run directory\n");
		return 1;
	}
	char graph[300], conf[1024];
	make_graph(r.dir, graph, sizeof(graph));
	snprintf(conf, sizeof(conf), "[socket]\npath = @SOCK@\n[source]\ngraph = %s\nrate = 100\nseed = 3\n", graph);
	mcd_run_config(&r, conf);
	const char *const args[] = {NULL};
	if (mcd_run_start_ready(&r, args)) {
		test_stream(&r);
		CHECK(mcd_run_alive(&r));
		mcd_run_terminate(&r, 10000, "graph source");
	}
	/* a damaged graph file: --check and start name it and the key */
	char bad[300];
	snprintf(bad, sizeof(bad), "%s/bad.mg", r.dir);
	FILE *f = fopen(bad, "w");
	fputs("MCMGRAPH\x01", f);
	fclose(f);
	snprintf(conf, sizeof(conf), "[socket]\npath = @SOCK@\n[source]\ngraph = %s\n", bad);
	mcd_run_config(&r, conf);
	const char *const check[] = {"--check", NULL};
	CHECK(mcd_run_start(&r, check, NULL));
	CHECK(mcd_run_wait_exit(&r, 10000) == 1);
	char *log = mcd_read_file(r.log);
	CHECK_MSG(log && strstr(log, "bad.mg") && strstr(log, "[source] graph") && strstr(log, "truncated"), "%s",
		  log ? log : "(no log)");
	free(log);
	/* cameras and a graph: one or the other */
	snprintf(conf, sizeof(conf), "[socket]\npath = @SOCK@\n[camera a]\ndriver = sim\n[source]\ngraph = %s\n", graph);
	mcd_run_config(&r, conf);
	CHECK(mcd_run_start(&r, check, NULL));
	CHECK(mcd_run_wait_exit(&r, 10000) == 1);
	log = mcd_read_file(r.log);
	CHECK_MSG(log && strstr(log, "[source] graph replaces the cameras"), "%s", log ? log : "(no log)");
	free(log);
	char cmd[700];
	snprintf(cmd, sizeof(cmd), "rm -f %s/*.bvh %s/*.mg", r.dir, r.dir);
	if (system(cmd) != 0)
		printf("could not clean %s\n", r.dir);
	mcd_run_cleanup(&r);
	return mc_test_failures ? 1 : 0;
}
