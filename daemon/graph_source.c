/* graph_source: graph walks as mocapd's skeleton stream (graph_source.h). */
#include "graph_source.h"

#include "log.h"
#include "textbuf.h"
#include "base/mc_parse.h"
#include "base/mc_thread.h"
#include "base/mc_time.h"

#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define J MC_MOTION_JOINTS

struct mcd_graph_source {
	mc_motion_graph graph;
	srv_server *srv;
	double rate;
	int kind; /* the edges walked: MC_EDGE_ESSENTIAL or MC_EDGE_MOTION */
	char file[PATH_MAX];
	pthread_t thread;
	bool running;
	atomic_bool stop;
	atomic_uint_fast64_t published;
	uint64_t start_ns;
	/* the walker and the poses around the output time: under lock (the
	 * main thread steers, the source thread walks) */
	pthread_mutex_t lock;
	mc_walker *walker;
	mc_vec3 a[J], b[J]; /* walker poses at times ta and ta + 1 / fps */
	double ta;
	char target[128];   /* what the walk does, for messages */
};

static int where_err(const mcd_config *cfg, const char *key, mc_err *err)
{
	char where[PATH_MAX + 64];
	return mc_err_prefix(err, "%s", mcd_config_where(cfg, "source", key, where, sizeof(where)));
}

int mcd_graph_source_check(const mcd_config *cfg, mc_err *err)
{
	mc_motion_graph *g = malloc(sizeof(*g));
	if (!g)
		return mc_err_set(err, "out of memory");
	int rc = mc_graph_load(cfg->source.graph, g, err);
	if (rc)
		where_err(cfg, "graph", err);
	else
		mc_graph_free(g);
	free(g);
	return rc;
}

/* ---- the skeleton ---- */

static void make_def(const mc_motion_skel *s, srv_skeleton_def *def)
{
	memset(def, 0, sizeof(*def));
	def->njoints = J;
	def->rig_is_world = true; /* the walk is in a world frame: z up, floor at 0 */
	for (int j = 0; j < J; j++) {
		snprintf(def->name[j], sizeof(def->name[j]), "%s", mc_motion_joint_name(j));
		def->parent[j] = s->parent[j];
		def->rest_offset[j] = s->offset[j];
	}
}

/* The published pose: the walker's orientations, and positions from the
 * root by the definition (parent + parent's rotation * rest offset).  The
 * walker's own positions are the database's, interpolated: their bones
 * differ from the rest offsets by centimetres and change length, so a
 * client driving a rig by local rotations (VMC) would not reproduce
 * them; this way every client sees the same body. */
static void make_skeleton(const mc_motion_skel *s, const mc_vec3 *pose, uint64_t t_ns, mc_skeleton *sk)
{
	mc_mat3 R[J];
	mc_motion_orientations(s, pose, R);
	memset(sk, 0, sizeof(*sk));
	sk->timestamp_ns = t_ns;
	sk->state = MC_TRACK_OK;
	sk->njoints = J;
	for (int j = 0; j < J; j++) {
		mc_skeleton_joint *o = &sk->joints[j];
		int p = s->parent[j];
		o->orientation = mc_quat_from_m3(R[j]);
		/* through the published quaternion, so the check a client
		 * makes holds to rounding */
		o->position = p < 0 ? pose[j]
				    : mc_v3_add(sk->joints[p].position,
						mc_quat_rotate(sk->joints[p].orientation, s->offset[j]));
		o->confidence = 1;
	}
	/* The rest lengths move the feet by millimetres: keep the lowest
	 * joint as high as the walker's, on the floor and not under it. */
	double want = INFINITY, have = INFINITY;
	for (int j = 0; j < J; j++) {
		want = fmin(want, pose[j].z);
		have = fmin(have, sk->joints[j].position.z);
	}
	for (int j = 0; j < J; j++)
		sk->joints[j].position.z += want - have;
}

/* ---- the thread ---- */

/* The pose at output time t (seconds since start): the walker steps at
 * the graph's frame rate; output poses interpolate. */
static void pose_at(mcd_graph_source *gs, double t, mc_vec3 *out)
{
	double dt = 1 / gs->graph.db.fps;
	pthread_mutex_lock(&gs->lock);
	while (t > gs->ta + dt) {
		memcpy(gs->a, gs->b, sizeof(gs->a));
		mc_walker_next(gs->walker, gs->b);
		gs->ta += dt;
	}
	double x = (t - gs->ta) / dt;
	for (int j = 0; j < J; j++)
		out[j] = mc_v3_add(mc_v3_scale(gs->a[j], 1 - x), mc_v3_scale(gs->b[j], x));
	pthread_mutex_unlock(&gs->lock);
}

static void *source_thread(void *arg)
{
	mcd_graph_source *gs = arg;
	mc_thread_set_name("mocapd-graph");
	mc_skeleton *sk = malloc(sizeof(*sk));
	if (!sk) {
		mcd_error("graph source: out of memory");
		return NULL;
	}
	uint64_t period = (uint64_t)(1e9 / gs->rate), next = mc_now_ns(), failures = 0;
	mc_vec3 pose[J];
	for (uint64_t seq = 1; !atomic_load(&gs->stop); seq++) {
		uint64_t now = mc_now_ns();
		pose_at(gs, (double)(now - gs->start_ns) * 1e-9, pose);
		make_skeleton(&gs->graph.db.skel, pose, now, sk);
		mc_err err;
		if (gs->srv && srv_publish(gs->srv, sk, seq, &err) && failures++ % 1000 == 0) /* not every frame */
			mcd_warn("graph source: %s (%llu times)", err.msg, (unsigned long long)failures);
		atomic_store(&gs->published, seq);
		next += period;
		now = mc_now_ns();
		if (next > now)
			mc_sleep_until_ns(next);
		else
			next = now; /* late (a slow machine): no burst to catch up */
	}
	free(sk);
	return NULL;
}

mcd_graph_source *mcd_graph_source_start(const mcd_config *cfg, srv_server *srv, mc_err *err)
{
	mcd_graph_source *gs = calloc(1, sizeof(*gs));
	srv_skeleton_def *def = calloc(1, sizeof(*def));
	if (!gs || !def) {
		free(gs);
		free(def);
		mc_err_set(err, "out of memory");
		return NULL;
	}
	pthread_mutex_init(&gs->lock, NULL);
	gs->srv = srv;
	gs->rate = cfg->source.rate;
	gs->kind = cfg->source.kind;
	snprintf(gs->file, sizeof(gs->file), "%s", cfg->source.graph);
	snprintf(gs->target, sizeof(gs->target), "walking at random");
	if (mc_graph_load(cfg->source.graph, &gs->graph, err)) {
		where_err(cfg, "graph", err);
		goto fail;
	}
	gs->walker = mc_walker_new(&gs->graph, cfg->source.kind, (uint64_t)cfg->source.seed, err);
	if (!gs->walker) {
		where_err(cfg, "graph", err);
		goto fail;
	}
	mc_walker_next(gs->walker, gs->a);
	mc_walker_next(gs->walker, gs->b);
	make_def(&gs->graph.db.skel, def);
	if (srv && srv_set_skeleton_def(srv, def, err))
		goto fail;
	gs->start_ns = mc_now_ns();
	if (pthread_create(&gs->thread, NULL, source_thread, gs) != 0) {
		mc_err_set(err, "graph source: cannot start its thread: %s", strerror(errno));
		goto fail;
	}
	gs->running = true;
	mcd_info("source: %s, %d frames in %d clips at %g fps, %s graph, %g skeletons/s", gs->file, gs->graph.db.nframes,
		 gs->graph.db.nclips, gs->graph.db.fps, cfg->source.kind == MC_EDGE_MOTION ? "motion" : "Essential",
		 gs->rate);
	free(def);
	return gs;
fail:
	free(def);
	mcd_graph_source_stop(gs);
	return NULL;
}

void mcd_graph_source_stop(mcd_graph_source *gs)
{
	if (!gs)
		return;
	atomic_store(&gs->stop, true);
	if (gs->running)
		pthread_join(gs->thread, NULL);
	mc_walker_free(gs->walker);
	mc_graph_free(&gs->graph);
	pthread_mutex_destroy(&gs->lock);
	free(gs);
}

/* ---- steering ---- */


int mcd_graph_steer_parse(const char *arg, mc_steer *s, char *msg, size_t cap)
{
	char buf[256], *w[5] = {0}, *save = NULL;
	int n = 0;
	snprintf(buf, sizeof(buf), "%s", arg ? arg : "");
	for (char *t = strtok_r(buf, " \t", &save); t; t = strtok_r(NULL, " \t", &save)) {
		if (n == 4) {
			snprintf(msg, cap, "too many words in '%s'", arg);
			return -1;
		}
		w[n++] = t;
	}
	memset(s, 0, sizeof(*s));
	s->speed = -1;
	double v;
	if (n == 1 && strcmp(w[0], "none") == 0) {
		s->kind = MC_STEER_NONE;
	} else if (n == 2 && strcmp(w[0], "class") == 0) {
		if (strlen(w[1]) >= sizeof(s->cls)) {
			snprintf(msg, cap, "class '%s' is too long", w[1]);
			return -1;
		}
		s->kind = MC_STEER_CLASS;
		snprintf(s->cls, sizeof(s->cls), "%s", w[1]);
	} else if (n == 2 && strcmp(w[0], "frame") == 0) {
		if (!mc_parse_double(w[1], &v) || v < 0 || v != floor(v) || v > 2e9) {
			snprintf(msg, cap, "frame '%s' is not a frame number", w[1]);
			return -1;
		}
		s->kind = MC_STEER_FRAME;
		s->frame = (int)v;
	} else if (n == 2 && strcmp(w[0], "speed") == 0) {
		if (!mc_parse_double(w[1], &v) || v < 0 || v > 20) {
			snprintf(msg, cap, "speed '%s' is not a speed of 0..20 m/s", w[1]);
			return -1;
		}
		s->kind = MC_STEER_DIRECTION;
		s->direction_deg = NAN; /* any direction */
		s->speed = v;
	} else if ((n == 2 || n == 4) && strcmp(w[0], "direction") == 0) {
		if (!mc_parse_double(w[1], &v)) {
			snprintf(msg, cap, "direction '%s' is not a number of degrees", w[1]);
			return -1;
		}
		s->kind = MC_STEER_DIRECTION;
		s->direction_deg = v;
		if (n == 4) {
			if (strcmp(w[2], "speed") != 0 || !mc_parse_double(w[3], &v) || v < 0 || v > 20) {
				snprintf(msg, cap, "expected 'speed M/S' (0..20) after the direction, got '%s %s'", w[2],
					 w[3]);
				return -1;
			}
			s->speed = v;
		}
	} else {
		snprintf(msg, cap, "'%s' is not a target (class NAME, frame N, direction DEG [speed M/S], speed M/S, none)",
			 arg ? arg : "");
		return -1;
	}
	return 0;
}

/* Appends "first-last" runs of the frames in the walk's component. */
static void append_frames(const mc_graph_adj *a, char *msg, size_t cap, size_t *len)
{
	bool any = false;
	for (int f = 0; f < a->n; f++) {
		if (!a->in_scc[f] || (f > 0 && a->in_scc[f - 1]))
			continue;
		int last = f;
		while (last + 1 < a->n && a->in_scc[last + 1])
			last++;
		mcd_appendf(msg, cap, len, "%s%d-%d", any ? ", " : "", f, last);
		any = true;
	}
}

static bool clip_in(const mc_motion_db *db, const mc_graph_adj *a, int c)
{
	for (int f = db->clips[c].first; f < db->clips[c].first + db->clips[c].nframes; f++)
		if (a->in_scc[f])
			return true;
	return false;
}

/* The answer to "steer list": the classes and frames the walk can be
 * steered to (those of its strongly connected component, what
 * mc_walker_steer accepts) and what DEG means, so that a client need not
 * guess. */
static int steer_targets(mcd_graph_source *gs, char *msg, size_t cap)
{
	mc_graph_adj a;
	mc_err err;
	if (mc_graph_adj_build(&gs->graph, gs->kind, &a, &err)) {
		snprintf(msg, cap, "%s", err.msg);
		return -1;
	}
	const mc_motion_db *db = &gs->graph.db;
	size_t len = 0;
	msg[0] = 0;
	mcd_appendf(msg, cap, &len, "classes:");
	for (int c = 0, n = 0; c < db->nclips; c++) {
		bool listed = !db->clips[c].cls[0] || !clip_in(db, &a, c);
		for (int e = 0; e < c && !listed; e++)
			listed = strcmp(db->clips[e].cls, db->clips[c].cls) == 0 && clip_in(db, &a, e);
		if (!listed)
			mcd_appendf(msg, cap, &len, "%s %s", n++ ? "," : "", db->clips[c].cls);
	}
	mcd_appendf(msg, cap, &len, "; frames: ");
	append_frames(&a, msg, cap, &len);
	mcd_appendf(msg, cap, &len, " (of 0-%d); direction DEG: the heading about +z (up) in the walk's world frame, "
			      "0 = +x, 90 = +y, counter-clockwise seen from above; speed M/S: 0..20",
		    db->nframes - 1);
	mc_graph_adj_free(&a);
	return 0;
}

int mcd_graph_source_steer(mcd_graph_source *gs, const char *arg, char *msg, size_t cap)
{
	if (arg && strcmp(arg, "list") == 0)
		return steer_targets(gs, msg, cap);
	mc_steer s;
	if (mcd_graph_steer_parse(arg, &s, msg, cap))
		return -1;
	mc_err err;
	pthread_mutex_lock(&gs->lock);
	int rc = mc_walker_steer(gs->walker, &s, &err);
	if (rc == 0)
		snprintf(gs->target, sizeof(gs->target), "%s", s.kind == MC_STEER_NONE ? "walking at random" : arg);
	pthread_mutex_unlock(&gs->lock);
	if (rc) {
		snprintf(msg, cap, "%s", err.msg);
		return -1;
	}
	snprintf(msg, cap, "steering: %s", s.kind == MC_STEER_NONE ? "walking at random" : arg);
	return 0;
}

uint64_t mcd_graph_source_published(mcd_graph_source *gs)
{
	return atomic_load(&gs->published);
}

void mcd_graph_source_status(mcd_graph_source *gs, srv_status *st)
{
	memset(st, 0, sizeof(*st));
	st->tracker_state = SRV_TRACKER_OK;
	st->publish_fps = gs->rate;
	st->frames_published = atomic_load(&gs->published);
	st->start_ns = gs->start_ns;
	pthread_mutex_lock(&gs->lock);
	snprintf(st->device, sizeof(st->device), "graph source: %.40s", gs->target);
	pthread_mutex_unlock(&gs->lock);
}
