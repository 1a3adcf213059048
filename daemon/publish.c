#include "publish.h"

#include "latency.h"

#include "log.h"
#include "recorder.h"
#include "textbuf.h"
#include "base/mc_thread.h"
#include "track/mc_skeleton_filter.h"

#include <errno.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#define QUEUE_LEN 8
#define IDLE_WAKE_NS (100 * MC_NS_PER_MS) /* how often an idle thread looks up */

struct mcd_publisher {
	srv_server *srv;
	FILE *out;
	pthread_t thread;
	pthread_mutex_t lock;
	pthread_cond_t cond;
	bool stop, print, busy;
	mcd_output queue[QUEUE_LEN];
	int head, count;
	mcd_publish_stats stats;
	mcd_latency latency;    /* stage times of the newest published sets */
	uint64_t t0_ns;
	bool have_t0;
	atomic_uint_fast64_t heartbeat;
	char pose_dir[4096];    /* "" = do not save poses */
	uint64_t server_seq;    /* publisher thread only */
	mcd_recorder *recorder; /* NULL: none; set before frames flow */
	uint64_t logged_errors; /* publisher thread only */
	/* The output filter's settings (under the lock; `filter_gen` counts
	 * their changes) and its state (publisher thread only). */
	bool filter_on;
	mc_one_euro_params filter_params;
	double filter_max_gap_s;
	unsigned filter_gen, filter_seen_gen;
	mc_skeleton_filter filter;
	mc_skeleton filtered;
	/* The newest tracked pose's joints, for the detector's hint (under the
	 * lock; mcd_publisher_latest_joints). */
	int latest_n;
	uint64_t latest_ns;
	mc_vec3 latest[MC_MAX_JOINTS];
};

/* The settings handle() works with, taken under the lock. */
typedef struct {
	bool print, filter_on;
	mc_one_euro_params filter_params;
	double filter_max_gap_s;
	unsigned filter_gen;
	char pose_dir[4096];
} handle_settings;

void mcd_format_output(const mcd_output *o, uint64_t t0_ns, char *buf, size_t cap)
{
	double t = o->timestamp_ns >= t0_ns ? (double)(o->timestamp_ns - t0_ns) / 1e9 : 0;
	size_t len = 0;
	if (cap)
		buf[0] = 0;
	if (!o->tracked) {
		mcd_appendf(buf, cap, &len, "frame %llu t=%.3f cams %d/%d (not tracked)", (unsigned long long)o->seq, t,
			    o->present, o->ncams);
		return;
	}
	const mc_skeleton *sk = &o->sk;
	mcd_appendf(buf, cap, &len, "frame %llu t=%.3f %s %.1fms cams %d/%d", (unsigned long long)o->seq, t,
		    mc_track_state_name(sk->state), sk->track_ms, o->present, o->ncams);
	for (int j = 0; j < sk->njoints; j++) {
		const mc_vec3 *p = &sk->joints[j].position;
		mcd_appendf(buf, cap, &len, " %s=(%.3f,%.3f,%.3f)", sk->joints[j].name, p->x, p->y, p->z);
	}
}

static void save_pose(mcd_publisher *p, const mcd_output *o, const char *dir)
{
	char path[4200];
	snprintf(path, sizeof(path), "%s/pose_%05llu.json", dir, (unsigned long long)o->frame);
	FILE *f = fopen(path, "w");
	if (!f) {
		if (++p->logged_errors <= 3)
			mcd_warn("save poses: %s: %s", path, strerror(errno));
		return;
	}
	fprintf(f, "{\"note\": \"frame %llu, t=%.6f s, %s\",\n \"pose\": [", (unsigned long long)o->frame,
		(double)o->timestamp_ns / 1e9, mc_track_state_name(o->sk.state));
	for (int k = 0; k < o->ndof; k++)
		fprintf(f, "%s%.9g", k ? ", " : "", o->pose[k]);
	fprintf(f, "]}\n");
	if (fclose(f) != 0 && ++p->logged_errors <= 3)
		mcd_warn("save poses: %s: write error", path);
}

/* The skeleton clients get: o's own, or (filter on) p->filtered.  A
 * change of the filter's settings starts it again.  Publisher thread only. */
static const mc_skeleton *client_skeleton(mcd_publisher *p, const mcd_output *o, const handle_settings *s)
{
	if (s->filter_gen != p->filter_seen_gen) {
		p->filter_seen_gen = s->filter_gen;
		mc_skeleton_filter_init(&p->filter, &s->filter_params, s->filter_max_gap_s);
	}
	if (!s->filter_on || !o->tracked)
		return &o->sk;
	p->filtered = o->sk;
	mc_skeleton_filter_apply(&p->filter, &p->filtered);
	return &p->filtered;
}

/* Returns 1 if the server refused the frame; *published_ns: when a
 * tracked skeleton was handed to the server (0: none was).  Publisher
 * thread only; o is its own copy (the printed line shows the filtered
 * skeleton, so it is swapped in after the recorder had the tracker's). */
static int handle(mcd_publisher *p, mcd_output *o, const handle_settings *s, uint64_t *published_ns)
{
	int failed = 0;
	*published_ns = 0;
	const mc_skeleton *sk = client_skeleton(p, o, s);
	uint64_t seq = o->tracked ? ++p->server_seq : p->server_seq;
	if (o->tracked && p->srv) {
		mc_err err;
		if (srv_publish(p->srv, sk, seq, &err) != 0) {
			failed = 1;
			if (++p->logged_errors <= 3)
				mcd_warn("publish: %s", err.msg);
		} else {
			*published_ns = mc_now_ns();
		}
	}
	/* Clients first: the take, the files and the text line can wait. */
	mcd_recorder_push_pose(p->recorder, o, seq);
	if (o->tracked && s->pose_dir[0])
		save_pose(p, o, s->pose_dir);
	if (s->print) {
		if (sk != &o->sk)
			o->sk = *sk;
		if (!p->have_t0) {
			p->t0_ns = o->timestamp_ns;
			p->have_t0 = true;
		}
		char line[4096];
		mcd_format_output(o, p->t0_ns, line, sizeof(line));
		fprintf(p->out, "%s\n", line);
		fflush(p->out);
	}
	return failed;
}

static void *publish_main(void *arg)
{
	mcd_publisher *p = arg;
	mc_thread_set_name("mocapd-publish");
	pthread_mutex_lock(&p->lock);
	for (;;) {
		while (!p->count && !p->stop) {
			struct timespec ts = mc_cond_deadline(IDLE_WAKE_NS);
			pthread_cond_timedwait(&p->cond, &p->lock, &ts);
			atomic_fetch_add(&p->heartbeat, 1);
		}
		if (!p->count && p->stop)
			break;
		mcd_output *o = malloc(sizeof(*o));
		if (o)
			*o = p->queue[p->head];
		p->head = (p->head + 1) % QUEUE_LEN;
		p->count--;
		p->busy = true;
		handle_settings s = {.print = p->print,
				     .filter_on = p->filter_on,
				     .filter_params = p->filter_params,
				     .filter_max_gap_s = p->filter_max_gap_s,
				     .filter_gen = p->filter_gen};
		memcpy(s.pose_dir, p->pose_dir, sizeof(s.pose_dir));
		pthread_mutex_unlock(&p->lock);
		uint64_t published_ns = 0;
		int failed = o ? handle(p, o, &s, &published_ns) : 0;
		atomic_fetch_add(&p->heartbeat, 1);
		pthread_mutex_lock(&p->lock);
		if (published_ns)
			mcd_latency_add(&p->latency, o, published_ns);
		free(o);
		p->stats.server_errors += (uint64_t)failed;
		p->busy = false;
		p->stats.published++;
	}
	pthread_mutex_unlock(&p->lock);
	return NULL;
}

mcd_publisher *mcd_publisher_create(srv_server *srv, FILE *out, bool print, mc_err *err)
{
	mcd_publisher *p = calloc(1, sizeof(*p));
	if (!p) {
		mc_err_set(err, "publisher: out of memory");
		return NULL;
	}
	p->srv = srv;
	p->out = out ? out : stdout;
	p->print = print;
	mc_one_euro_params_default(&p->filter_params);
	p->filter_max_gap_s = 0.2;
	mc_skeleton_filter_init(&p->filter, &p->filter_params, p->filter_max_gap_s);
	pthread_mutex_init(&p->lock, NULL);
	mc_cond_init_monotonic(&p->cond);
	int rc = pthread_create(&p->thread, NULL, publish_main, p);
	if (rc) {
		mc_err_set(err, "publisher: cannot start its thread: %s", strerror(rc));
		pthread_mutex_destroy(&p->lock);
		pthread_cond_destroy(&p->cond);
		free(p);
		return NULL;
	}
	return p;
}

void mcd_publisher_destroy(mcd_publisher *p)
{
	if (!p)
		return;
	pthread_mutex_lock(&p->lock);
	p->stop = true;
	pthread_cond_signal(&p->cond);
	pthread_mutex_unlock(&p->lock);
	pthread_join(p->thread, NULL);
	pthread_mutex_destroy(&p->lock);
	pthread_cond_destroy(&p->cond);
	free(p);
}

void mcd_publisher_push(mcd_publisher *p, const mcd_output *o)
{
	pthread_mutex_lock(&p->lock);
	if (p->count == QUEUE_LEN) {
		p->head = (p->head + 1) % QUEUE_LEN;
		p->count--;
		p->stats.dropped++;
	}
	p->queue[(p->head + p->count) % QUEUE_LEN] = *o;
	p->count++;
	if (o->tracked && (o->sk.state == MC_TRACK_OK || o->sk.state == MC_TRACK_UNCERTAIN)) {
		p->latest_n = o->sk.njoints;
		p->latest_ns = o->timestamp_ns;
		for (int j = 0; j < o->sk.njoints; j++)
			p->latest[j] = o->sk.joints[j].position;
	}
	pthread_cond_signal(&p->cond);
	pthread_mutex_unlock(&p->lock);
}

int mcd_publisher_latest_joints(mcd_publisher *p, uint64_t now_ns, uint64_t max_age_ns, mc_vec3 *out, int max)
{
	pthread_mutex_lock(&p->lock);
	int n = p->latest_n < max ? p->latest_n : max;
	bool fresh = p->latest_ns <= now_ns + max_age_ns && now_ns <= p->latest_ns + max_age_ns;
	if (!fresh)
		n = 0;
	for (int j = 0; j < n; j++)
		out[j] = p->latest[j];
	pthread_mutex_unlock(&p->lock);
	return n;
}

void mcd_publisher_set_print(mcd_publisher *p, bool print)
{
	pthread_mutex_lock(&p->lock);
	p->print = print;
	pthread_mutex_unlock(&p->lock);
}

void mcd_publisher_set_filter(mcd_publisher *p, const mc_one_euro_params *params, double max_gap_s)
{
	pthread_mutex_lock(&p->lock);
	bool on = params != NULL;
	mc_one_euro_params kept = params ? *params : p->filter_params;
	if (on != p->filter_on || memcmp(&kept, &p->filter_params, sizeof(kept)) || max_gap_s != p->filter_max_gap_s)
		p->filter_gen++;
	p->filter_on = on;
	p->filter_params = kept;
	p->filter_max_gap_s = max_gap_s;
	pthread_mutex_unlock(&p->lock);
}

void mcd_publisher_set_recorder(mcd_publisher *p, mcd_recorder *r)
{
	pthread_mutex_lock(&p->lock);
	p->recorder = r;
	pthread_mutex_unlock(&p->lock);
}

void mcd_publisher_save_poses(mcd_publisher *p, const char *dir)
{
	pthread_mutex_lock(&p->lock);
	snprintf(p->pose_dir, sizeof(p->pose_dir), "%s", dir ? dir : "");
	pthread_mutex_unlock(&p->lock);
}

void mcd_publisher_latency(mcd_publisher *p, srv_latency_status *out)
{
	pthread_mutex_lock(&p->lock);
	mcd_latency_summary(&p->latency, out);
	pthread_mutex_unlock(&p->lock);
}

void mcd_publisher_stats(mcd_publisher *p, mcd_publish_stats *st)
{
	pthread_mutex_lock(&p->lock);
	*st = p->stats;
	pthread_mutex_unlock(&p->lock);
}

uint64_t mcd_publisher_heartbeat(mcd_publisher *p)
{
	return atomic_load(&p->heartbeat);
}

bool mcd_publisher_idle(mcd_publisher *p)
{
	pthread_mutex_lock(&p->lock);
	bool idle = !p->count && !p->busy;
	pthread_mutex_unlock(&p->lock);
	return idle;
}
