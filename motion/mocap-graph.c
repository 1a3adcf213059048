/* mocap-graph: motion graphs over recorded takes and BVH files
 * (docs/MOTION_GRAPH.md, docs/man/mocap-graph.1.scd).
 *
 *   mocap-graph build --out GRAPH [options] [CLASS=]FILE.bvh|TAKE_DIR...
 *   mocap-graph walk GRAPH --seconds S --bvh OUT.bvh [--seed N] [steering]
 *   mocap-graph blend GRAPH --class C --speed V --bvh OUT.bvh
 *   mocap-graph info GRAPH
 *   mocap-graph check GRAPH [--seconds S] [--seed N]
 *   mocap-graph compare [--alpha A,B,...] [options] [CLASS=]FILE...
 */
#include "base/mc_file.h"
#include "base/mc_parse.h"
#include "base/mc_time.h"
#include "body/mc_model.h"
#include "mc_install_paths.h" /* generated: MC_VERSION */
#include "motion/mc_motion_param.h"
#include "motion/mc_motion_synth.h"
#include "motion_take.h"

#include <errno.h>
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>

#define PROG "mocap-graph"
#define fail(code, ...) mc_fail_exit(PROG, code, __VA_ARGS__)

static void usage(FILE *f)
{
	fprintf(f,
		"usage: mocap-graph build --out GRAPH [options] [CLASS=]FILE.bvh|TAKE_DIR...\n"
		"       mocap-graph walk GRAPH --seconds S --bvh OUT.bvh [--seed N] [walk options]\n"
		"       mocap-graph blend GRAPH --class C --speed V --bvh OUT.bvh\n"
		"       mocap-graph info GRAPH\n"
		"       mocap-graph check GRAPH [--seconds S] [--seed N] [--graph KIND]\n"
		"       mocap-graph compare [--alpha A,B,...] [options] [CLASS=]FILE...\n"
		"Motion graphs over recorded takes and BVH files (docs/MOTION_GRAPH.md).\n"
		"\n"
		"build and compare:\n"
		"  --out GRAPH        the graph file to write (build)\n"
		"  --fps F            frames per second of the database (15)\n"
		"  --alpha A          duration weight per frame of E = D + alpha L (0.0001);\n"
		"                     compare: a comma-separated list\n"
		"  --window MIN:MAX   transition window lengths in seconds (0.33:1)\n"
		"  --tau T            velocity weight of the frame distance, seconds (0.1)\n"
		"  --model FILE       take bone lengths from this body model (default: the\n"
		"                     default model's)\n"
		"  --threads N        threads (0: every CPU, the default)\n"
		"  --quiet            no progress on stderr\n"
		"  A file may be prefixed with its motion class: walk=02_01.bvh.\n"
		"walk and check:\n"
		"  --seconds S        length of the walk\n"
		"  --bvh FILE         write the walk as BVH (walk)\n"
		"  --csv FILE         write joint positions as CSV (walk)\n"
		"  --seed N           random seed (1)\n"
		"  --rate HZ          output frame rate (the graph's)\n"
		"  --graph KIND       essential (default) or motion\n"
		"  --class C          reach motion class C and stay in it\n"
		"  --frame N          reach database frame N\n"
		"  --direction DEG    head towards DEG, counter-clockwise from +x\n"
		"  --speed V          walk: move at about V m/s (with --direction or alone);\n"
		"                     blend: the speed to blend the node of --class to\n"
		"  -h, --help         this text\n"
		"  -V, --version      the version\n");
}

typedef struct {
	const char *out, *bvh, *csv, *model, *alphas;
	double fps, alpha, tau, wmin, wmax, seconds, rate, direction, speed;
	int threads, quiet, frame;
	uint64_t seed;
	int mask;
	const char *cls;
} options;

static double number(const char *s, const char *opt)
{
	double v;
	if (!mc_parse_double(s, &v))
		fail(2, "%s: '%s' is not a number", opt, s);
	return v;
}

static void parse(int argc, char **argv, options *o)
{
	static const struct option opts[] = {
		{"out", required_argument, NULL, 'o'},     {"fps", required_argument, NULL, 'f'},
		{"alpha", required_argument, NULL, 'a'},   {"window", required_argument, NULL, 'w'},
		{"tau", required_argument, NULL, 't'},     {"model", required_argument, NULL, 'm'},
		{"threads", required_argument, NULL, 'j'}, {"quiet", no_argument, NULL, 'q'},
		{"seconds", required_argument, NULL, 's'}, {"bvh", required_argument, NULL, 'b'},
		{"csv", required_argument, NULL, 'c'},     {"seed", required_argument, NULL, 'S'},
		{"rate", required_argument, NULL, 'r'},    {"graph", required_argument, NULL, 'g'},
		{"class", required_argument, NULL, 'C'},   {"frame", required_argument, NULL, 'F'},
		{"direction", required_argument, NULL, 'd'}, {"speed", required_argument, NULL, 'v'},
		{"help", no_argument, NULL, 'h'},          {"version", no_argument, NULL, 'V'},
		{NULL, 0, NULL, 0},
	};
	*o = (options){.fps = 15, .alpha = 0.0001, .tau = 0.1, .wmin = 0.33, .wmax = 1.0, .seconds = -1, .rate = 0,
		       .direction = NAN, .speed = -1, .frame = -1, .seed = 1, .mask = MC_EDGE_ESSENTIAL};
	int c;
	while ((c = getopt_long(argc, argv, "hV", opts, NULL)) != -1) {
		switch (c) {
		case 'o': o->out = optarg; break;
		case 'f': o->fps = number(optarg, "--fps"); break;
		case 'a': o->alphas = optarg; o->alpha = strchr(optarg, ',') ? o->alpha : number(optarg, "--alpha"); break;
		case 'w':
			if (sscanf(optarg, "%lf:%lf", &o->wmin, &o->wmax) != 2 || !(o->wmin > 0) || o->wmax < o->wmin)
				fail(2, "--window: '%s' is not MIN:MAX seconds with 0 < MIN <= MAX", optarg);
			break;
		case 't': o->tau = number(optarg, "--tau"); break;
		case 'm': o->model = optarg; break;
		case 'j': o->threads = (int)number(optarg, "--threads"); break;
		case 'q': o->quiet = 1; break;
		case 's': o->seconds = number(optarg, "--seconds"); break;
		case 'b': o->bvh = optarg; break;
		case 'c': o->csv = optarg; break;
		case 'S': o->seed = (uint64_t)number(optarg, "--seed"); break;
		case 'r': o->rate = number(optarg, "--rate"); break;
		case 'g':
			if (strcmp(optarg, "essential") == 0)
				o->mask = MC_EDGE_ESSENTIAL;
			else if (strcmp(optarg, "motion") == 0)
				o->mask = MC_EDGE_MOTION;
			else
				fail(2, "--graph: '%s' is neither essential nor motion", optarg);
			break;
		case 'C': o->cls = optarg; break;
		case 'F': o->frame = (int)number(optarg, "--frame"); break;
		case 'd': o->direction = number(optarg, "--direction"); break;
		case 'v': o->speed = number(optarg, "--speed"); break;
		case 'h': usage(stdout); exit(0);
		case 'V': printf("mocap-graph %s\n", MC_VERSION); exit(0);
		default: usage(stderr); exit(2);
		}
	}
	if (!(o->fps >= 1 && o->fps <= 240))
		fail(2, "--fps: %g is outside 1..240", o->fps);
	if (!(o->alpha > 0))
		fail(2, "--alpha: %g must be positive", o->alpha);
	if (o->threads < 0)
		fail(2, "--threads: must be 0 or more");
}

/* ---- building ---- */

/* Progress lines on stderr, every 5% of a stage. */
typedef struct {
	const char *stage;
	int last;
} progress_state;

static void progress(void *ctx, const char *stage, int done, int total)
{
	progress_state *ps = ctx;
	if (ps->stage != stage) {
		ps->stage = stage;
		ps->last = -5;
	}
	int pct = (int)(100.0 * done / total);
	if (pct >= ps->last + 5 || done == total) {
		ps->last = pct;
		fprintf(stderr, "%s: %s %d%% (%d of %d)\n", PROG, stage, pct, done, total);
	}
}

static bool is_dir(const char *p)
{
	struct stat st;
	return stat(p, &st) == 0 && S_ISDIR(st.st_mode);
}

static void load_db(const options *o, char **files, int nfiles, mc_motion_db *db)
{
	mc_err err;
	mc_motion_skel skel;
	mc_motion_skel_default(&skel);
	if (o->model) {
		mc_model *m = malloc(sizeof(*m));
		if (!m || mc_model_load(o->model, m, &err) || mc_motion_skel_from_model(m, &skel, &err))
			fail(1, "%s", m ? err.msg : "out of memory");
		free(m);
	}
	mc_motion_db_init(db, o->fps, &skel);
	if (nfiles == 0)
		fail(2, "no input files");
	for (int i = 0; i < nfiles; i++) {
		char cls[MC_MOTION_CLASS_MAX] = "";
		const char *path = files[i], *eq = strchr(path, '='), *slash = strchr(path, '/');
		if (eq && (!slash || eq < slash)) { /* CLASS=FILE */
			snprintf(cls, sizeof(cls), "%.*s", (int)(eq - path), path);
			path = eq + 1;
		}
		int rc = is_dir(path) ? motion_db_add_take(db, path, cls, &err) : mc_motion_db_add_bvh(db, path, cls, &err);
		if (rc)
			fail(1, "%s", err.msg);
	}
}

static void cost_params(const options *o, mc_cost_params *p)
{
	mc_cost_params_default(p, o->fps);
	p->tau = o->tau;
	p->lmin = (int)lround(o->wmin * o->fps);
	p->lmax = (int)lround(o->wmax * o->fps);
	if (p->lmin < 2)
		p->lmin = 2;
	if (p->lmax < p->lmin)
		p->lmax = p->lmin;
	if (p->lmax > MC_DTW_MAX_WINDOW)
		fail(2, "--window: %d frames at %g fps is longer than %d", p->lmax, o->fps, MC_DTW_MAX_WINDOW);
	p->lstep = (p->lmax - p->lmin) / 2 > 0 ? (p->lmax - p->lmin) / 2 : 1;
	p->threads = o->threads;
}

static double peak_mib(void)
{
	struct rusage ru;
	getrusage(RUSAGE_SELF, &ru);
	return ru.ru_maxrss / 1024.0;
}

/* CPU seconds of every thread so far (steadier than wall time on a busy machine). */
static double cpu_seconds(void)
{
	struct rusage ru;
	getrusage(RUSAGE_SELF, &ru);
	return (double)(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) + (ru.ru_utime.tv_usec + ru.ru_stime.tv_usec) * 1e-6;
}


/* Loads the files into a database and builds its cost matrix (with
 * progress on stderr when `progress` and not --quiet); returns the
 * seconds the costs took. */
static double build_costs(const options *o, char **files, int nfiles, bool progress_on, mc_motion_db *db,
			  mc_cost_params *p, mc_cost_matrix *m)
{
	load_db(o, files, nfiles, db);
	cost_params(o, p);
	/* static: the graph build after this reports through the same callback */
	static progress_state ps = {NULL, -5};
	if (progress_on && !o->quiet) {
		p->progress = progress;
		p->progress_ctx = &ps;
		fprintf(stderr, "%s: %d clips, %d frames at %g fps, %d threads\n", PROG, db->nclips, db->nframes, db->fps,
			mc_motion_threads(p->threads));
	}
	mc_err err;
	uint64_t t0 = mc_now_ns();
	if (mc_cost_matrix_build(db, p, m, &err))
		fail(1, "%s", err.msg);
	return mc_ms_since(t0) / 1000;
}

static int cmd_build(const options *o, char **files, int nfiles)
{
	if (!o->out)
		fail(2, "build: --out GRAPH is required");
	mc_motion_db db;
	mc_cost_params p;
	mc_cost_matrix m;
	mc_err err;
	double t_cost = build_costs(o, files, nfiles, true, &db, &p, &m);
	mc_motion_graph g;
	mc_graph_stats st;
	uint64_t t1 = mc_now_ns();
	if (mc_graph_build(&db, &m, &p, o->alpha, &g, &st, &err))
		fail(1, "%s", err.msg);
	double t_graph = mc_ms_since(t1) / 1000;
	mc_cost_matrix_free(&m);
	if (mc_graph_save(&g, o->out, &err))
		fail(1, "%s", err.msg);
	int ness = 0, nmg = 0;
	for (int i = 0; i < g.nedges; i++) {
		ness += (g.edges[i].flags & MC_EDGE_ESSENTIAL) != 0;
		nmg += (g.edges[i].flags & MC_EDGE_MOTION) != 0;
	}
	printf("%s: %d frames, %d clips, %d Essential and %d motion-graph transitions, %d parametric nodes; "
	       "costs %.2f s, graphs %.2f s (CPU %.1f s in all), peak memory %.0f MiB\n",
	       o->out, g.db.nframes, g.db.nclips, ness, nmg, g.nparams, t_cost, t_graph, cpu_seconds(), peak_mib());
	mc_graph_free(&g);
	return 0;
}

/* ---- walking ---- */

static mc_motion_graph *load_graph(const char *path)
{
	mc_motion_graph *g = malloc(sizeof(*g));
	mc_err err;
	if (!g)
		fail(1, "out of memory");
	if (mc_graph_load(path, g, &err))
		fail(1, "%s", err.msg);
	return g;
}

static mc_walker *start_walk(const options *o, const mc_motion_graph *g)
{
	mc_err err;
	mc_walker *w = mc_walker_new(g, o->mask, o->seed, &err);
	if (!w)
		fail(1, "%s", err.msg);
	mc_steer s = {.kind = MC_STEER_NONE, .speed = o->speed};
	if (o->cls) {
		s.kind = MC_STEER_CLASS;
		snprintf(s.cls, sizeof(s.cls), "%s", o->cls);
	} else if (o->frame >= 0) {
		s.kind = MC_STEER_FRAME;
		s.frame = o->frame;
	} else if (isfinite(o->direction) || o->speed >= 0) {
		s.kind = MC_STEER_DIRECTION;
		s.direction_deg = o->direction; /* NAN: any direction, at a speed */
	}
	if (mc_walker_steer(w, &s, &err))
		fail(1, "%s", err.msg);
	return w;
}

/* The BVH and CSV outputs of walk and blend. */
typedef struct {
	const options *o;
	const mc_motion_skel *skel;
	FILE *bvh, *csv;
	take_def *def;
	take_pose *tp;
} writer;

static void writer_open(writer *wr, const options *o, const mc_motion_skel *skel, long n, double rate)
{
	*wr = (writer){.o = o, .skel = skel};
	wr->bvh = o->bvh ? mc_file_create_or_exit(PROG, o->bvh) : NULL;
	wr->csv = o->csv ? mc_file_create_or_exit(PROG, o->csv) : NULL;
	wr->def = malloc(sizeof(*wr->def));
	wr->tp = calloc(1, sizeof(*wr->tp));
	if (!wr->def || !wr->tp)
		fail(1, "out of memory");
	motion_take_def(skel, wr->def);
	if (wr->bvh) {
		take_bvh_write_hierarchy(wr->bvh, wr->def);
		take_bvh_write_motion(wr->bvh, (int)n, 1 / rate);
	}
	if (wr->csv) {
		fprintf(wr->csv, "time,transition");
		for (int j = 0; j < MC_MOTION_JOINTS; j++)
			fprintf(wr->csv, ",%s_x,%s_y,%s_z", mc_motion_joint_name(j), mc_motion_joint_name(j),
				mc_motion_joint_name(j));
		fputc('\n', wr->csv);
	}
}

static void writer_pose(writer *wr, double t, int synthetic, const mc_vec3 *pose)
{
	if (wr->bvh) {
		motion_take_pose(wr->skel, pose, wr->tp);
		take_bvh_write_pose(wr->bvh, wr->def, wr->tp);
	}
	if (wr->csv) {
		fprintf(wr->csv, "%.6f,%d", t, synthetic);
		for (int j = 0; j < MC_MOTION_JOINTS; j++)
			fprintf(wr->csv, ",%.5f,%.5f,%.5f", pose[j].x, pose[j].y, pose[j].z);
		fputc('\n', wr->csv);
	}
}

static void writer_close(writer *wr)
{
	if (wr->bvh)
		mc_file_close_or_exit(PROG, wr->bvh, wr->o->bvh);
	if (wr->csv)
		mc_file_close_or_exit(PROG, wr->csv, wr->o->csv);
	free(wr->def);
	free(wr->tp);
}

static int cmd_walk(const options *o, const char *graph)
{
	if (!(o->seconds > 0) || (!o->bvh && !o->csv))
		fail(2, "walk: --seconds S (> 0) and --bvh OUT.bvh (or --csv) are required");
	mc_motion_graph *g = load_graph(graph);
	mc_walker *w = start_walk(o, g);
	double rate = o->rate > 0 ? o->rate : g->db.fps;
	long n = lround(o->seconds * rate);
	writer wr;
	writer_open(&wr, o, &g->db.skel, n, rate);
	/* the walker steps at the graph's rate; output frames interpolate */
	mc_vec3 a[MC_MOTION_JOINTS], b[MC_MOTION_JOINTS], out[MC_MOTION_JOINTS];
	int syn = mc_walker_next(w, a);
	mc_walker_next(w, b);
	double tb = 1 / g->db.fps; /* time of b */
	for (long k = 0; k < n; k++) {
		double t = k / rate;
		while (t > tb) {
			memcpy(a, b, sizeof(a));
			syn = mc_walker_next(w, b);
			tb += 1 / g->db.fps;
		}
		double x = 1 - (tb - t) * g->db.fps;
		for (int j = 0; j < MC_MOTION_JOINTS; j++)
			out[j] = mc_v3_add(mc_v3_scale(a[j], 1 - x), mc_v3_scale(b[j], x));
		writer_pose(&wr, t, syn, out);
	}
	writer_close(&wr);
	fprintf(stderr, "%s: %ld frames at %g Hz, %ld transitions\n", PROG, n, rate, mc_walker_transitions(w));
	mc_walker_free(w);
	mc_graph_free(g);
	free(g);
	return 0;
}

/* A parametric node's motion at a speed (Casas): BVH and/or CSV at the
 * graph's rate, one pass of the aligned members. */
static int cmd_blend(const options *o, const char *graph)
{
	if (!o->cls || !(o->speed >= 0) || (!o->bvh && !o->csv))
		fail(2, "blend: --class C, --speed V and --bvh OUT.bvh (or --csv) are required");
	mc_motion_graph *g = load_graph(graph);
	int node = mc_param_find(g, o->cls);
	if (node < 0)
		fail(1, "%s: no parametric node of class '%s' (a class needs two clips or more)", graph, o->cls);
	mc_param_motion pm;
	mc_err err;
	if (mc_param_blend(g, node, o->speed, &pm, &err))
		fail(1, "%s", err.msg);
	writer wr;
	writer_open(&wr, o, &g->db.skel, pm.nframes, g->db.fps);
	for (int k = 0; k < pm.nframes; k++)
		writer_pose(&wr, k / g->db.fps, 1, pm.poses + (size_t)k * MC_MOTION_JOINTS);
	writer_close(&wr);
	printf("class '%s' at %.3f m/s: %s and %s, weight %.3f; %d frames (%.1f s) at %.3f m/s\n", o->cls, o->speed,
	       g->db.clips[pm.clip_a].name, g->db.clips[pm.clip_b].name, pm.w, pm.nframes, (pm.nframes - 1) / g->db.fps,
	       pm.speed);
	free(pm.poses);
	mc_graph_free(g);
	free(g);
	return 0;
}

/* ---- info and check ---- */

static int cmd_info(const char *graph)
{
	mc_motion_graph *g = load_graph(graph);
	int ness = 0, nmg = 0;
	for (int i = 0; i < g->nedges; i++) {
		ness += (g->edges[i].flags & MC_EDGE_ESSENTIAL) != 0;
		nmg += (g->edges[i].flags & MC_EDGE_MOTION) != 0;
	}
	printf("frames %d at %g fps, alpha %g, tau %g s, windows %d..%d frames (step %d)\n", g->db.nframes, g->db.fps,
	       g->alpha, g->tau, g->lmin, g->lmax, g->lstep);
	printf("transitions: %d Essential graph, %d motion graph\n", ness, nmg);
	for (int c = 0; c < g->db.nclips; c++)
		printf("clip %d: %s class '%s' frames %d..%d\n", c, g->db.clips[c].name, g->db.clips[c].cls,
		       g->db.clips[c].first, g->db.clips[c].first + g->db.clips[c].nframes - 1);
	for (int k = 0; k < g->nparams; k++) {
		printf("parametric node %d '%s':", k, g->params[k].cls);
		for (int i = 0; i < g->params[k].nmembers; i++)
			printf(" %s (%.2f m/s, %.1f deg/s)", g->db.clips[g->params[k].clip[i]].name, g->params[k].speed[i],
			       g->params[k].turn[i]);
		printf("\n");
	}
	for (int k = 0; k < g->nparam_edges; k++)
		printf("parametric edge %u -> %u: frames %u -> %u, E %.4f\n", g->param_edges[k].from_node,
		       g->param_edges[k].to_node, g->param_edges[k].from, g->param_edges[k].to, g->param_edges[k].E);
	mc_graph_free(g);
	free(g);
	return 0;
}

/* A walk of S seconds at the graph's rate: the largest velocity and
 * acceleration jumps at transition poses against those inside the
 * recorded clips, and the lowest foot. */
static int cmd_check(const options *o, const char *graph)
{
	mc_motion_graph *g = load_graph(graph);
	mc_walker *w = start_walk(o, g);
	double seconds = o->seconds > 0 ? o->seconds : 600;
	long n = lround(seconds * g->db.fps);
	mc_vec3(*p)[MC_MOTION_JOINTS] = malloc(sizeof(*p) * (size_t)n);
	uint8_t *syn = malloc((size_t)n);
	if (!p || !syn)
		fail(1, "out of memory");
	for (long k = 0; k < n; k++)
		syn[k] = (uint8_t)mc_walker_next(w, p[k]);
	double clip_v, clip_a;
	mc_motion_db_jumps(&g->db, &clip_v, &clip_a);
	double tv = 0, ta = 0, ov = 0, oa = 0, zmin = INFINITY, step = 0;
	/* a jump over frames one of which is a transition pose counts for the
	 * transitions: three frames for velocity, four for acceleration */
	for (long k = 0; k + 2 < n; k++) {
		double v = mc_pose_vel_jump(p[k], p[k + 1], p[k + 2], g->db.fps);
		if (syn[k] || syn[k + 1] || syn[k + 2])
			tv = fmax(tv, v);
		else
			ov = fmax(ov, v);
		if (k + 3 >= n)
			continue;
		double a = mc_pose_acc_jump(p[k], p[k + 1], p[k + 2], p[k + 3], g->db.fps);
		if (syn[k] || syn[k + 1] || syn[k + 2] || syn[k + 3])
			ta = fmax(ta, a);
		else
			oa = fmax(oa, a);
	}
	for (long k = 0; k < n; k++) {
		for (int j = 0; j < MC_MOTION_JOINTS; j++)
			zmin = fmin(zmin, p[k][j].z);
		if (k > 0)
			for (int j = 0; j < MC_MOTION_JOINTS; j++)
				step = fmax(step, mc_v3_norm(mc_v3_sub(p[k][j], p[k - 1][j])));
	}
	long ntr = mc_walker_transitions(w);
	printf("walk %.0f s (%ld poses at %g fps, %s graph, seed %llu): %ld transitions\n", seconds, n, g->db.fps,
	       o->mask == MC_EDGE_MOTION ? "motion" : "Essential", (unsigned long long)o->seed, ntr);
	printf("velocity jump, m/s:      transitions %.3f  walk elsewhere %.3f  recorded clips %.3f\n", tv, ov, clip_v);
	printf("acceleration jump, m/s2: transitions %.1f  walk elsewhere %.1f  recorded clips %.1f\n", ta, oa, clip_a);
	printf("largest joint step per frame %.3f m, lowest joint %.4f m above the floor\n", step, zmin);
	int ok = tv <= clip_v * (1 + 1e-9) && zmin >= -1e-9; /* placed poses: rounding */
	printf("%s\n", ok ? "continuous: transition jumps within the recorded clips' range, no joint below the floor"
			  : "NOT continuous: see above");
	free(p);
	free(syn);
	mc_walker_free(w);
	mc_graph_free(g);
	free(g);
	return ok ? 0 : 1;
}

/* ---- compare: Boukhayma & Boyer fig. 9 ---- */

static int cmd_compare(const options *o, char **files, int nfiles)
{
	mc_motion_db db;
	mc_cost_params p;
	mc_cost_matrix m;
	mc_err err;
	double t_cost = build_costs(o, files, nfiles, false, &db, &p, &m);
	size_t n = (size_t)db.nframes;
	uint8_t *keep = malloc(n * n);
	if (!keep)
		fail(1, "out of memory");
	printf("%d frames (%d clips) at %g fps, windows %d..%d frames, costs in %.2f s on %d threads\n", db.nframes,
	       db.nclips, db.fps, p.lmin, p.lmax, t_cost, mc_motion_threads(p.threads));
	printf("%-8s | %-34s | %-34s\n", "", "Essential graph", "motion graph");
	printf("%-8s | %10s %10s %12s | %10s %10s %12s | %s\n", "alpha", "mean", "variance", "density", "mean",
	       "variance", "density", "unreachable (E / M)");
	const char *list = o->alphas ? o->alphas : "0.001,0.003,0.01,0.03,0.1";
	char buf[256];
	snprintf(buf, sizeof(buf), "%s", list);
	for (char *save = NULL, *tok = strtok_r(buf, ",", &save); tok; tok = strtok_r(NULL, ",", &save)) {
		double alpha = number(tok, "--alpha");
		mc_graph_stats se, sm;
		if (mc_graph_essential(&db, &m, p.lmax, alpha, p.threads, keep, &se, &err))
			fail(1, "%s", err.msg);
		mc_graph_motion(&db, &m, p.lmax, keep);
		if (mc_graph_stats_of(&db, &m, alpha, keep, p.threads, &sm, &err))
			fail(1, "%s", err.msg);
		printf("%-8g | %10.4f %10.5f %12.3e | %10.4f %10.5f %12.3e | %.3f / %.3f\n", alpha, se.mean, se.var,
		       se.density, sm.mean, sm.var, sm.density, se.unreachable, sm.unreachable);
	}
	free(keep);
	mc_cost_matrix_free(&m);
	mc_motion_db_free(&db);
	return 0;
}

int main(int argc, char **argv)
{
	if (argc < 2) {
		usage(stderr);
		return 2;
	}
	if (strcmp(argv[1], "-h") == 0 || strcmp(argv[1], "--help") == 0) {
		usage(stdout);
		return 0;
	}
	if (strcmp(argv[1], "-V") == 0 || strcmp(argv[1], "--version") == 0) {
		printf("mocap-graph %s\n", MC_VERSION);
		return 0;
	}
	const char *cmd = argv[1];
	/* The command first: an unknown one is named as such, before its
	 * options or arguments are judged. */
	static const char *const commands[] = {"build", "walk", "blend", "info", "check", "compare"};
	bool known = false;
	for (size_t i = 0; i < sizeof(commands) / sizeof(commands[0]); i++)
		known = known || strcmp(cmd, commands[i]) == 0;
	if (!known)
		fail(2, "'%s' is not a command (build, walk, blend, info, check, compare; mocap-graph -h for help)", cmd);
	options o;
	parse(argc - 1, argv + 1, &o);
	char **rest = argv + 1 + optind;
	int nrest = argc - 1 - optind;
	if (strcmp(cmd, "build") == 0)
		return cmd_build(&o, rest, nrest);
	if (strcmp(cmd, "compare") == 0)
		return cmd_compare(&o, rest, nrest);
	if (nrest != 1)
		fail(2, "%s: needs exactly one GRAPH file", cmd);
	if (strcmp(cmd, "walk") == 0)
		return cmd_walk(&o, rest[0]);
	if (strcmp(cmd, "info") == 0)
		return cmd_info(rest[0]);
	if (strcmp(cmd, "blend") == 0)
		return cmd_blend(&o, rest[0]);
	if (strcmp(cmd, "check") == 0)
		return cmd_check(&o, rest[0]);
	fail(2, "'%s' is not a command (build, walk, blend, info, check, compare)", cmd);
}
