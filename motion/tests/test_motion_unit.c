/* Tests of core/motion and mocap-graph on synthetic BVH clips (no shared
 * data): retargeting and the floor, DTW and its slope constraint, the
 * transition cost of a periodic clip, the Essential graph's defining
 * property, the motion graph's local minima, the graph file and its
 * errors, walks (continuity, floor, bone lengths, steering), and the
 * command line's BVH against its CSV. */
#include "body/mc_bvh.h"
#include "motion/mc_motion_param.h"
#include "motion/mc_motion_synth.h"
#include "motion_fixture.h"
#include "motion_take.h"
#include "test_util.h"

static char graph_bin[4200]; /* BUILD/bin/mocap-graph, beside this test's BUILD */

#include <stdint.h>

#define J MC_MOTION_JOINTS

static char dir[256];

static void path_in(char *out, size_t n, const char *name) { snprintf(out, n, "%s/%s", dir, name); }

static void make_db(mc_motion_db *db, double fps)
{
	char a[300], b[300], c[300];
	path_in(a, sizeof(a), "straight.bvh");
	path_in(b, sizeof(b), "fast.bvh");
	path_in(c, sizeof(c), "turn.bvh");
	CHECK(fixture_write(a, 6, 60, 1.0, 120, 0) == 0);
	CHECK(fixture_write(b, 5, 60, 0.8, 170, 0) == 0);
	CHECK(fixture_write(c, 6, 60, 1.0, 110, 40) == 0);
	mc_motion_db_init(db, fps, NULL);
	mc_err err;
	CHECK_MSG(mc_motion_db_add_bvh(db, a, "walk", &err) == 0, "%s", err.msg);
	CHECK_MSG(mc_motion_db_add_bvh(db, b, "walk", &err) == 0, "%s", err.msg);
	CHECK_MSG(mc_motion_db_add_bvh(db, c, "turn", &err) == 0, "%s", err.msg);
}

static void check_lengths(const mc_motion_skel *s, const mc_vec3 *p, double tol, const char *what)
{
	for (int j = 1; j < J; j++) {
		double len = mc_v3_norm(mc_v3_sub(p[j], p[s->parent[j]])), want = mc_v3_norm(s->offset[j]);
		CHECK_MSG(fabs(len - want) < tol, "%s: bone %s %.4f m, skeleton %.4f m", what, mc_motion_joint_name(j), len,
			  want);
	}
}

static void test_database(const mc_motion_db *db)
{
	CHECK(db->nclips == 3);
	CHECK(db->clips[0].nframes == (int)floor(5.9833 * db->fps + 1e-9) + 1);
	for (int c = 0; c < db->nclips; c++) {
		double zmin = INFINITY;
		for (int f = db->clips[c].first; f < db->clips[c].first + db->clips[c].nframes; f++) {
			check_lengths(&db->skel, mc_motion_frame(db, f), 1e-9, "database");
			for (int j = 0; j < J; j++)
				zmin = fmin(zmin, mc_motion_frame(db, f)[j].z);
		}
		CHECK_MSG(fabs(zmin) < 1e-12, "clip %d: lowest joint at %g, not on the floor", c, zmin);
	}
	/* the straight walk faces +y (BVH +z) and moves along it at 1.2 m/s
	 * scaled by the leg ratio */
	mc_floor_frame f0 = mc_motion_floor_frame(mc_motion_frame(db, 0));
	CHECK_MSG(fabs(remainder(f0.heading - M_PI / 2, 2 * M_PI)) < 0.05, "heading %g", f0.heading);
	float speed, turn;
	mc_clip_params(db, 0, &speed, &turn);
	double scale = (0.5 + 0.48) / (0.45 + 0.42);
	CHECK_MSG(fabs(speed - 1.2 * scale) < 0.05, "speed %g m/s, want %g", speed, 1.2 * scale);
	CHECK_MSG(fabs(turn) < 1, "turn %g deg/s", turn);
	mc_clip_params(db, 2, &speed, &turn);
	CHECK_MSG(fabs(turn - 40) < 2, "turning clip: %g deg/s, want 40", turn);
	/* the built-in skeleton is the default body model's */
	mc_model *model = malloc(sizeof(*model));
	mc_motion_skel from_model, builtin;
	mc_err err;
	mc_motion_skel_default(&builtin);
	if (mc_model_load("config/models/default.json", model, &err) == 0) {
		CHECK_MSG(mc_motion_skel_from_model(model, &from_model, &err) == 0, "%s", err.msg);
		for (int j = 0; j < J; j++)
			CHECK(mc_v3_norm(mc_v3_sub(from_model.offset[j], builtin.offset[j])) < 1e-12 &&
			      from_model.parent[j] == builtin.parent[j]);
		snprintf(model->joints[5].name, sizeof(model->joints[5].name), "wrist");
		CHECK(mc_motion_skel_from_model(model, &from_model, &err) == -1 && strstr(err.msg, "left_wrist"));
	} else {
		printf("config/models/default.json: %s (not run from the repository root?)\n", err.msg);
	}
	free(model);
	/* floor frames: there and back */
	mc_floor_frame ff = {0.3, -1.2, 0.7};
	mc_vec3 p = mc_v3(1, 2, 3), q = mc_floor_to_world(ff, mc_floor_from_world(ff, p));
	CHECK(mc_v3_norm(mc_v3_sub(p, q)) < 1e-12);
}

static void test_dtw(void)
{
	mc_dtw_ws *ws = mc_dtw_ws_new();
	float w[10 * 10];
	/* identical windows: the diagonal, at zero cost */
	for (int s = 0; s < 6; s++)
		for (int t = 0; t < 6; t++)
			w[s * 6 + t] = (float)abs(s - t);
	mc_dtw_fill(ws, w, 6, 6);
	double sum;
	CHECK(mc_dtw_end(ws, 6, &sum) == 6 && sum == 0);
	uint8_t path[32][2];
	CHECK(mc_dtw_path(ws, 6, path) == 6);
	for (int k = 0; k < 6; k++)
		CHECK(path[k][0] == k && path[k][1] == k);
	/* a target twice as slow: the path repeats source frames */
	for (int s = 0; s < 5; s++)
		for (int t = 0; t < 10; t++)
			w[s * 10 + t] = (float)fabs(s - t / 2.0);
	mc_dtw_fill(ws, w, 5, 10);
	int n = mc_dtw_end(ws, 5, &sum);
	CHECK_MSG(n >= 10 && sum < 2.6, "slow target: length %d sum %g", n, sum);
	/* the slope constraint: 2 source frames cannot cover 10 target frames
	 * with at most 3 horizontal steps in a row */
	for (int i = 0; i < 20; i++)
		w[i] = 0;
	mc_dtw_fill(ws, w, 2, 10);
	CHECK(mc_dtw_end(ws, 2, &sum) == -1);
	mc_dtw_fill(ws, w, 2, 7); /* 3 h, 1 diagonal, 3 h: just fits */
	CHECK(mc_dtw_end(ws, 2, &sum) == 7);
	mc_dtw_ws_free(ws);
}

static void test_costs(const mc_motion_db *db, const mc_cost_matrix *m, const mc_cost_params *p)
{
	const int n = m->n;
	for (int a = 0; a < n; a++)
		CHECK(m->d[(size_t)a * n + a] == 0);
	/* the straight walk is periodic (1 s): leaving frame i for the frame one
	 * period and a window later costs almost nothing */
	int per = (int)lround(db->fps);
	int i = 10;
	double best = INFINITY;
	for (int v = i + per; v < i + per + p->lmax; v++)
		if (v < db->clips[0].nframes)
			best = fmin(best, m->t[(size_t)i * n + v].D);
	CHECK_MSG(best < 0.01, "periodic clip: best transition one period on costs %g m", best);
	/* half a period on: the legs are swapped, the cost is large */
	double half = m->t[(size_t)i * n + i + per / 2 + p->lmin - 1].D;
	CHECK_MSG(half > 5 * best && half > 0.03, "half a period on: %g m (one period: %g)", half, best);
	/* windows fit their clips */
	for (int u = 0; u < n; u++)
		for (int v = 0; v < n; v++) {
			const mc_transition *t = &m->t[(size_t)u * n + v];
			if (!isfinite(t->D))
				continue;
			const mc_motion_clip *cu = &db->clips[db->clip_of[u]], *cv = &db->clips[db->clip_of[v]];
			if (u + t->li > cu->first + cu->nframes || v - t->lj + 1 < cv->first || t->L < t->li ||
			    t->L < t->lj) {
				CHECK_MSG(0, "transition %d -> %d: windows %d, %d, path %d out of their clips", u, v, t->li, t->lj,
					  t->L);
				return;
			}
		}
}

static void test_graphs(const mc_motion_db *db, const mc_cost_matrix *m, const mc_cost_params *p)
{
	const int n = db->nframes;
	uint8_t *keep = malloc((size_t)n * n);
	mc_graph_stats ess, ess_sparse, mg, none;
	mc_err err;
	double alpha = 1e-3;
	CHECK_MSG(mc_graph_essential(db, m, p->lmax, alpha, 2, keep, &ess, &err) == 0, "%s", err.msg);
	/* its edges keep every shortest distance of the complete digraph */
	CHECK(mc_graph_stats_of(db, m, alpha, keep, 2, &ess_sparse, &err) == 0);
	CHECK_MSG(fabs(ess.mean - ess_sparse.mean) < 1e-6 * ess.mean && fabs(ess.unreachable - ess_sparse.unreachable) < 1e-12,
		  "Essential graph %g, complete digraph %g", ess_sparse.mean, ess.mean);
	long kept = 0, all = 0;
	for (size_t i = 0; i < (size_t)n * n; i++) {
		kept += keep[i];
		all += isfinite(m->t[i].D);
	}
	CHECK_MSG(kept > 0 && kept < all / 4, "Essential graph keeps %ld of %ld transitions", kept, all);
	/* the original edges alone reach less, at a higher cost */
	memset(keep, 0, (size_t)n * n);
	CHECK(mc_graph_stats_of(db, m, alpha, keep, 1, &none, &err) == 0);
	CHECK(none.unreachable > ess.unreachable);
	/* the motion graph: local minima only, never better than the Essential */
	mc_graph_motion(db, m, p->lmax, keep);
	int checked = 0;
	for (int u = 1; u + 1 < n && checked < 50; u++)
		for (int v = 1; v + 1 < n; v++) {
			if (!keep[(size_t)u * n + v] || db->clip_of[u - 1] != db->clip_of[u + 1] ||
			    db->clip_of[v - 1] != db->clip_of[v + 1])
				continue;
			float d = m->t[(size_t)u * n + v].D;
			for (int du = -1; du <= 1; du++)
				for (int dv = -1; dv <= 1; dv++) {
					float o = m->t[(size_t)(u + du) * n + v + dv].D;
					CHECK_MSG(!(o < d) || (db->clip_of[u] == db->clip_of[v] && abs(v + dv - u - du) <= p->lmax),
						  "motion graph edge %d -> %d (%g) beside a lower %g", u, v, d, o);
				}
			checked++;
		}
	CHECK(checked > 0);
	CHECK(mc_graph_stats_of(db, m, alpha, keep, 2, &mg, &err) == 0);
	CHECK_MSG(ess.mean <= mg.mean * (1 + 1e-9), "Essential mean %g above the motion graph's %g", ess.mean, mg.mean);
	printf("alpha %g: Essential mean %.4f var %.5f density %.4f; motion graph mean %.4f var %.5f density %.4f\n",
	       alpha, ess.mean, ess.var, ess.density, mg.mean, mg.var, mg.density);
	free(keep);
}

static void test_file(mc_motion_graph *g)
{
	char path[300], bad[300];
	path_in(path, sizeof(path), "g.mg");
	path_in(bad, sizeof(bad), "bad.mg");
	mc_err err;
	CHECK_MSG(mc_graph_save(g, path, &err) == 0, "%s", err.msg);
	mc_motion_graph h;
	CHECK_MSG(mc_graph_load(path, &h, &err) == 0, "%s", err.msg);
	CHECK(h.db.nframes == g->db.nframes && h.nedges == g->nedges && h.nparams == g->nparams);
	CHECK(h.alpha == g->alpha && h.lmin == g->lmin && h.lmax == g->lmax);
	for (int i = 0; i < g->nedges; i++)
		CHECK(memcmp(&h.edges[i], &g->edges[i], sizeof(mc_edge)) == 0);
	for (size_t i = 0; i < (size_t)g->db.nframes * J; i++)
		CHECK(mc_v3_norm(mc_v3_sub(h.db.pos[i], g->db.pos[i])) < 1e-6);
	CHECK(strcmp(h.db.clips[2].cls, "turn") == 0);
	mc_graph_free(&h);
	/* damaged files: each error names the file and what is wrong */
	size_t n;
	char *data = NULL;
	{
		FILE *f = fopen(path, "rb");
		fseek(f, 0, SEEK_END);
		n = (size_t)ftell(f);
		rewind(f);
		data = malloc(n);
		CHECK(fread(data, 1, n, f) == n);
		fclose(f);
	}
	struct {
		size_t at, len; /* len 0: flip the byte at `at` */
		const char *want;
	} cases[] = {
		{0, 0, "magic"}, {8, 0, "version"}, {n / 2, 0, "checksum"}, {n - 1, 0, "checksum"}, {0, n / 3, "truncated"},
		{0, 10, "truncated"},
	};
	for (size_t c = 0; c < sizeof(cases) / sizeof(cases[0]); c++) {
		FILE *f = fopen(bad, "wb");
		if (cases[c].len) {
			fwrite(data, 1, cases[c].len, f);
		} else {
			data[cases[c].at] ^= 0x5a;
			fwrite(data, 1, n, f);
			data[cases[c].at] ^= 0x5a;
		}
		fclose(f);
		int rc = mc_graph_load(bad, &h, &err);
		CHECK_MSG(rc == -1 && strstr(err.msg, cases[c].want) &&
				  strstr(err.msg, "bad.mg"),
			  "case %zu: rc %d, '%s' (want '%s')", c, rc, err.msg, cases[c].want);
	}
	free(data);
	CHECK(mc_graph_load("/nonexistent/g.mg", &h, &err) == -1 && strstr(err.msg, "/nonexistent/g.mg"));
}

static double heading_of(const mc_vec3 *p) { return mc_motion_floor_frame(p).heading; }

static void test_walks(const mc_motion_graph *g)
{
	mc_err err;
	double clip_v, clip_a;
	mc_motion_db_jumps(&g->db, &clip_v, &clip_a);
	for (int kind = 0; kind < 2; kind++) {
		int mask = kind ? MC_EDGE_MOTION : MC_EDGE_ESSENTIAL;
		mc_walker *w = mc_walker_new(g, mask, 7, &err);
		CHECK_MSG(w, "%s", err.msg);
		if (!w)
			return;
		int n = (int)(120 * g->db.fps);
		mc_vec3(*p)[J] = malloc(sizeof(*p) * (size_t)n);
		for (int k = 0; k < n; k++)
			mc_walker_next(w, p[k]);
		double v = 0, zmin = INFINITY;
		for (int k = 0; k + 2 < n; k++)
			v = fmax(v, mc_pose_vel_jump(p[k], p[k + 1], p[k + 2], g->db.fps));
		for (int k = 0; k < n; k++) {
			check_lengths(&g->db.skel, p[k], 1e-6, "walk");
			for (int j = 0; j < J; j++)
				zmin = fmin(zmin, p[k][j].z);
		}
		printf("%s graph walk 120 s: %ld transitions, velocity jump %.3f m/s (clips %.3f), lowest joint %.4f m\n",
		       kind ? "motion" : "Essential", mc_walker_transitions(w), v, clip_v, zmin);
		CHECK(mc_walker_transitions(w) >= 5);
		/* the motion graph keeps every local minimum, costly ones too (no
		 * threshold, as in Boukhayma's comparison): a looser bound */
		CHECK_MSG(v <= (kind ? 3 : 1.5) * clip_v, "velocity jump %g against %g in the clips", v, clip_v);
		CHECK(zmin >= -1e-9);
		free(p);
		mc_walker_free(w);
	}
	/* steering: reach the turning class; then head for a direction */
	mc_walker *w = mc_walker_new(g, MC_EDGE_ESSENTIAL, 3, &err);
	mc_steer s = {.kind = MC_STEER_CLASS, .speed = -1};
	snprintf(s.cls, sizeof(s.cls), "turn");
	CHECK_MSG(mc_walker_steer(w, &s, &err) == 0, "%s", err.msg);
	mc_vec3 pose[J];
	int in_class = 0;
	for (int k = 0; k < 20 * g->db.fps; k++) {
		mc_walker_next(w, pose);
		in_class += k > 10 * g->db.fps &&
			    strcmp(g->db.clips[g->db.clip_of[mc_walker_node(w)]].cls, "turn") == 0;
	}
	CHECK_MSG(in_class > 9 * g->db.fps, "in class 'turn' for %d of the last 10 s of frames", in_class);
	snprintf(s.cls, sizeof(s.cls), "dance");
	CHECK(mc_walker_steer(w, &s, &err) == -1 && strstr(err.msg, "dance"));
	s = (mc_steer){.kind = MC_STEER_DIRECTION, .direction_deg = -90, .speed = -1};
	CHECK(mc_walker_steer(w, &s, &err) == 0);
	double err_sum = 0;
	int cnt = 0;
	for (int k = 0; k < 40 * g->db.fps; k++) {
		mc_walker_next(w, pose);
		if (k > 20 * g->db.fps) {
			err_sum += fabs(remainder(heading_of(pose) + M_PI / 2, 2 * M_PI));
			cnt++;
		}
	}
	printf("steered towards -90 deg: mean heading error %.1f deg\n", err_sum / cnt * 180 / M_PI);
	CHECK_MSG(err_sum / cnt < 45 * M_PI / 180, "mean heading error %g deg", err_sum / cnt * 180 / M_PI);
	/* a speed alone: that of the fast walk, the fastest clip */
	float fast, turn;
	mc_clip_params(&g->db, 1, &fast, &turn);
	s = (mc_steer){.kind = MC_STEER_DIRECTION, .direction_deg = NAN, .speed = fast};
	CHECK(mc_walker_steer(w, &s, &err) == 0);
	mc_vec3 prev[J];
	double dist = 0;
	int frames = 0;
	for (int k = 0; k < 40 * g->db.fps; k++) {
		memcpy(prev, pose, sizeof(prev));
		mc_walker_next(w, pose);
		if (k > 20 * g->db.fps) {
			dist += hypot(pose[0].x - prev[0].x, pose[0].y - prev[0].y);
			frames++;
		}
	}
	double speed = dist / (frames / g->db.fps);
	printf("steered to %.2f m/s: %.2f m/s over the last 20 s\n", fast, speed);
	CHECK_MSG(fabs(speed - fast) < 0.1 * fast, "steered to %g m/s, moves at %g", fast, speed);
	mc_walker_free(w);
}

/* A take recorded by mocapd (poses.mcr: a definition, then poses at the
 * camera rate) becomes a clip: here the first clip's frames written as a
 * take at the database's rate come back as they were. */
static void write_take(const char *take, const mc_motion_db *db, int nframes, bool drop_toe)
{
	mkdir(take, 0755);
	char path[400];
	snprintf(path, sizeof(path), "%s/poses.mcr", take);
	take_file f;
	mc_err err;
	static uint8_t buf[64 + 64 * TAKE_MAX_JOINTS];
	static take_def def;
	static take_pose pose;
	memset(&def, 0, sizeof(def));
	def.id = 1;
	def.njoints = drop_toe ? J - 1 : J;
	for (int j = 0; j < def.njoints; j++) {
		snprintf(def.joints[j].name, sizeof(def.joints[j].name), "%s", mc_motion_joint_name(j));
		def.joints[j].parent = db->skel.parent[j];
	}
	CHECK_MSG(take_file_create(&f, path, &err) == 0, "%s", err.msg);
	size_t k = take_encode_def(&def, buf, sizeof(buf));
	CHECK(k > 0 && take_file_append(&f, TAKE_DEF, buf, k, NULL, 0, 1, &err) == 0);
	for (int i = 0; i < nframes; i++) {
		memset(&pose, 0, sizeof(pose));
		pose.seq = (uint64_t)i + 1;
		pose.capture_ns = 1000000000ull + (uint64_t)llround(i * 1e9 / db->fps);
		pose.def_id = 1;
		pose.njoints = def.njoints;
		for (int j = 0; j < def.njoints; j++) {
			mc_vec3 p = mc_motion_frame(db, i)[j];
			pose.joints[j].position[0] = p.x;
			pose.joints[j].position[1] = p.y;
			pose.joints[j].position[2] = p.z;
			pose.joints[j].orientation[0] = 1;
		}
		k = take_encode_pose(&pose, buf, sizeof(buf));
		CHECK(k > 0 && take_file_append(&f, TAKE_SKELETON, buf, k, NULL, 0, 2, &err) == 0);
	}
	take_file_close(&f);
}

static void test_take(const mc_motion_db *src)
{
	char take[300], bad[300];
	path_in(take, sizeof(take), "take1");
	path_in(bad, sizeof(bad), "take2");
	int n = src->clips[0].nframes;
	write_take(take, src, n, false);
	write_take(bad, src, n, true);
	mc_motion_db db;
	mc_err err;
	mc_motion_db_init(&db, src->fps, NULL);
	CHECK_MSG(motion_db_add_take(&db, take, "walk", &err) == 0, "%s", err.msg);
	CHECK(db.nclips == 1 && strcmp(db.clips[0].name, "take1") == 0 && strcmp(db.clips[0].cls, "walk") == 0);
	CHECK_MSG(db.nframes == n, "%d frames from a take of %d", db.nframes, n);
	double worst = 0;
	for (int f = 0; f < db.nframes && f < n; f++)
		for (int j = 0; j < J; j++)
			worst = fmax(worst, mc_v3_norm(mc_v3_sub(mc_motion_frame(&db, f)[j], mc_motion_frame(src, f)[j])));
	CHECK_MSG(worst < 1e-6, "take frames %g m from the clip's", worst);
	CHECK(motion_db_add_take(&db, bad, "", &err) == -1 && strstr(err.msg, "take2") && strstr(err.msg, "right_toe"));
	CHECK(motion_db_add_take(&db, "/nonexistent/take", "", &err) == -1 && strstr(err.msg, "/nonexistent/take"));
	mc_motion_db_free(&db);
	char cmd[700];
	snprintf(cmd, sizeof(cmd), "rm -rf %s %s", take, bad);
	CHECK(system(cmd) == 0);
}

/* Casas' parametric node: the two walks blended to a speed between
 * theirs reach it, continuously, on the floor, bones whole. */
static void test_param(const mc_motion_graph *g)
{
	mc_err err;
	int node = mc_param_find(g, "walk");
	CHECK(node == 0 && mc_param_find(g, "turn") == -1);
	if (node < 0)
		return;
	const mc_param_node *pn = &g->params[node];
	double lo = fmin(pn->speed[0], pn->speed[1]), hi = fmax(pn->speed[0], pn->speed[1]);
	double clip_v, clip_a, max_step = 0;
	mc_motion_db_jumps(&g->db, &clip_v, &clip_a);
	for (int f = 1; f < g->db.nframes; f++)
		if (g->db.clip_of[f] == g->db.clip_of[f - 1] && strcmp(g->db.clips[g->db.clip_of[f]].cls, "walk") == 0)
			for (int j = 0; j < J; j++)
				max_step = fmax(max_step, mc_v3_norm(mc_v3_sub(mc_motion_frame(&g->db, f)[j],
									mc_motion_frame(&g->db, f - 1)[j])));
	for (int i = 0; i < 3; i++) {
		double target = lo + (hi - lo) * (0.25 + 0.25 * i);
		mc_param_motion pm;
		CHECK_MSG(mc_param_blend(g, node, target, &pm, &err) == 0, "%s", err.msg);
		double step = 0, zmin = INFINITY;
		for (int k = 0; k < pm.nframes; k++) {
			const mc_vec3 *p = pm.poses + (size_t)k * J;
			check_lengths(&g->db.skel, p, 1e-6, "blend");
			for (int j = 0; j < J; j++) {
				zmin = fmin(zmin, p[j].z);
				if (k > 0)
					step = fmax(step, mc_v3_norm(mc_v3_sub(p[j], p[j - J])));
			}
		}
		printf("blend to %.3f m/s: weight %.3f, %.3f m/s, %d frames, largest step %.3f m (clips %.3f)\n", target,
		       pm.w, pm.speed, pm.nframes, step, max_step);
		CHECK(pm.clip_a != pm.clip_b && pm.w > 0.05 && pm.w < 0.95);
		CHECK_MSG(fabs(pm.speed - target) < 0.05 * target, "blend: %g m/s for %g", pm.speed, target);
		CHECK_MSG(step < 1.25 * max_step, "blend: a joint steps %g m, the clips %g at most", step, max_step);
		CHECK(zmin >= -1e-9);
		free(pm.poses);
	}
	/* outside the members: the nearest alone, no extrapolation */
	mc_param_motion pm;
	CHECK(mc_param_blend(g, node, 3 * hi, &pm, &err) == 0 && pm.clip_a == pm.clip_b && pm.w == 0);
	free(pm.poses);
	CHECK(mc_param_blend(g, 5, 1, &pm, &err) == -1 && strstr(err.msg, "node 5"));
}

/* mocap-graph end to end: the BVH it writes, read back and posed by
 * forward kinematics, matches the CSV of the same walk. */
static void test_command_line(void)
{
	char cmd[16384], out[4096], g[300], bvh[300], csv[300], a[300], c[300];
	path_in(g, sizeof(g), "cli.mg");
	path_in(bvh, sizeof(bvh), "walk.bvh");
	path_in(csv, sizeof(csv), "walk.csv");
	path_in(a, sizeof(a), "straight.bvh");
	path_in(c, sizeof(c), "turn.bvh");
	snprintf(cmd, sizeof(cmd), "%s build --quiet --fps 10 --threads 2 --out %s walk=%s turn=%s", graph_bin, g, a, c);
	int rc = mc_test_run(cmd, out, sizeof(out));
	CHECK_MSG(rc == 0 && strstr(out, "Essential"), "%s: %d %s", cmd, rc, out);
	snprintf(cmd, sizeof(cmd), "%s walk %s --seconds 30 --bvh %s --csv %s --seed 5 2>&1", graph_bin, g, bvh, csv);
	rc = mc_test_run(cmd, out, sizeof(out));
	CHECK_MSG(rc == 0, "%s: %d %s", cmd, rc, out);
	mc_bvh b;
	mc_err err;
	CHECK_MSG(mc_bvh_load(bvh, &b, &err) == 0, "%s", err.msg);
	FILE *f = fopen(csv, "r");
	CHECK(f != NULL);
	if (!f)
		return;
	char line[8192];
	CHECK(fgets(line, sizeof(line), f) != NULL);
	CHECK(b.nframes == 300);
	mc_xform *x = malloc(sizeof(*x) * (size_t)b.njoints);
	double worst = 0;
	for (int k = 0; k < b.nframes && fgets(line, sizeof(line), f); k++) {
		double v[2 + 3 * J];
		char *s = line;
		for (int i = 0; i < 2 + 3 * J; i++) {
			v[i] = strtod(s, &s);
			s++;
		}
		mc_bvh_fk(&b, k, x);
		for (int j = 0; j < J; j++) {
			int bj = mc_bvh_find(&b, mc_motion_joint_name(j));
			mc_vec3 p = mc_v3_scale(x[bj].t, 0.01); /* cm, BVH axes: (x, z, -y) of the world */
			mc_vec3 want = mc_v3(v[2 + 3 * j], v[4 + 3 * j], -v[3 + 3 * j]);
			double e = mc_v3_norm(mc_v3_sub(p, want));
			worst = fmax(worst, e);
		}
	}
	printf("BVH against CSV: worst %.2e m\n", worst);
	CHECK_MSG(worst < 2e-3, "BVH joints %.4f m from the walk's", worst);
	free(x);
	fclose(f);
	mc_bvh_free(&b);
	/* bad input names the file and line */
	char badbvh[300];
	path_in(badbvh, sizeof(badbvh), "bad.bvh");
	f = fopen(badbvh, "w");
	fputs("HIERARCHY\nROOT Hips\n{\n OFFSET 0 0\n}\n", f);
	fclose(f);
	snprintf(cmd, sizeof(cmd), "%s build --quiet --out %s/x.mg %s 2>&1", graph_bin, dir, badbvh);
	rc = mc_test_run(cmd, out, sizeof(out));
	CHECK_MSG(rc == 1 && strstr(out, "bad.bvh:5"), "bad BVH: %d '%s'", rc, out);
	snprintf(cmd, sizeof(cmd), "%s walk %s --seconds 1 --bvh %s/y.bvh 2>&1", graph_bin, badbvh, dir);
	rc = mc_test_run(cmd, out, sizeof(out));
	CHECK_MSG(rc == 1 && strstr(out, "bad.bvh") && strstr(out, "magic"), "not a graph: %d '%s'", rc, out);
	snprintf(cmd, sizeof(cmd), "%s walk %s --seconds 1 2>&1", graph_bin, g);
	rc = mc_test_run(cmd, out, sizeof(out));
	CHECK_MSG(rc == 2 && strstr(out, "--bvh"), "no output: %d '%s'", rc, out);
}

int main(void)
{
	find_graph_bin(graph_bin, sizeof(graph_bin));
	snprintf(dir, sizeof(dir), "/tmp/test_motion_unit.XXXXXX");
	if (!mkdtemp(dir)) {
		perror("mkdtemp");
		return 1;
	}
	test_dtw();
	mc_motion_db db;
	make_db(&db, 15);
	test_database(&db);
	test_take(&db);
	mc_cost_params p;
	mc_cost_params_default(&p, db.fps);
	p.threads = 2;
	mc_cost_matrix m;
	mc_err err;
	CHECK_MSG(mc_cost_matrix_build(&db, &p, &m, &err) == 0, "%s", err.msg);
	test_costs(&db, &m, &p);
	test_graphs(&db, &m, &p);
	mc_motion_graph g;
	mc_graph_stats st;
	CHECK_MSG(mc_graph_build(&db, &m, &p, 1e-3, &g, &st, &err) == 0, "%s", err.msg);
	CHECK(db.nframes == 0 && g.db.nframes > 0);
	CHECK_MSG(g.nparams == 1 && g.params[0].nmembers == 2 && strcmp(g.params[0].cls, "walk") == 0,
		  "parametric nodes: %d", g.nparams);
	if (g.nparams == 1)
		CHECK(fabs(g.params[0].speed[1] / g.params[0].speed[0] - 170.0 / 120) < 0.05);
	mc_cost_matrix_free(&m);
	test_file(&g);
	test_walks(&g);
	test_param(&g);
	mc_graph_free(&g);
	test_command_line();
	char cmd[300];
	snprintf(cmd, sizeof(cmd), "rm -rf %s", dir);
	if (getenv("MC_TEST_KEEP")) /* for a look at the files */
		printf("kept %s\n", dir);
	else if (system(cmd) != 0)
		printf("could not remove %s\n", dir);
	return mc_test_failures ? 1 : 0;
}
