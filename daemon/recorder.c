/* recorder: the recording thread (recorder.h, docs/RECORDING.md). */
#include "recorder.h"

#include "base/mc_thread.h"
#include "base/mc_time.h"
#include "frame_ring.h"
#include "log.h"

#include <errno.h>
#include <limits.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#define POSE_QUEUE 64   /* poses waiting for the thread (~0.9 MB) */
#define FRAME_QUEUE 512 /* frame references waiting: the rings hold the bytes */
#define HEAD_QUEUE 256  /* head poses waiting (a VR runtime sends 90-1000 per s) */

typedef struct {
	int cam;
	uint64_t generation;
	mc_ring_meta meta;
} frame_ref;

/* A skeleton waiting for the thread, with the keypoints it was tracked with. */
typedef struct {
	take_pose pose;
	int nkp;
	take_keypoint kp[MCD_OUTPUT_KEYPOINTS];
} queued_pose;

struct mcd_recorder {
	mcd_record_config cfg;
	char config_file[PATH_MAX], rig[PATH_MAX], model[PATH_MAX], actor[PATH_MAX];
	int ncams;
	mcd_camera *cams[MC_MAX_CAMERAS];
	char rig_cams[MC_MAX_CAMERAS][MCD_NAME_MAX];
	bool have_def;
	take_def def;

	pthread_t thread;
	bool thread_started;
	pthread_mutex_t lock;
	pthread_cond_t wake, done;
	bool quit;

	/* Queues, under lock. */
	queued_pose *poses;
	int pose_head, pose_count;
	frame_ref frames[FRAME_QUEUE];
	int frame_head, frame_count;
	take_head_pose heads[HEAD_QUEUE];
	int head_head, head_count;
	uint64_t head_drops;

	/* The take.  Under lock: `active` (items are taken), `busy` (a start or
	 * a finish is doing its file work, without the lock, so that the
	 * threads that hand items in never wait on the disk), `shown` (the
	 * counts for status), `queue_drops` and `last`.  `dir` and `info` are
	 * the starting thread's, then the recorder thread's. */
	bool active, busy, stop_requested;
	char dir[PATH_MAX];
	take_info info, shown;
	uint64_t queue_drops[MC_MAX_CAMERAS]; /* frames refused with a full queue */
	char last[PATH_MAX + 400]; /* what the last take ended with */
	take_file poses_file;
	take_file cam_files[MC_MAX_CAMERAS];
	uint64_t last_seq;
	int64_t realtime_offset_ns; /* CLOCK_REALTIME - CLOCK_MONOTONIC at the start */
	uint64_t next_sync_ns;

	uint8_t *buf; /* frame bytes copied out of a ring (thread only) */
	size_t cap;
	uint8_t pose_buf[64 + 64 * TAKE_MAX_JOINTS + 8 * TAKE_MAX_DOF + 16 * MCD_OUTPUT_KEYPOINTS];
};

/* The skeleton definition of a model (offsets scaled by the bone scales),
 * as the socket's SKELETON message has it. */
static void def_from_model(const mc_model *model, uint32_t id, take_def *def)
{
	memset(def, 0, sizeof(*def));
	def->id = id;
	def->njoints = model->njoints;
	for (int j = 0; j < model->njoints; j++) {
		snprintf(def->joints[j].name, sizeof(def->joints[j].name), "%s", model->joints[j].name);
		def->joints[j].parent = model->joints[j].parent;
		double s = model->bone_scale[j] > 0 ? model->bone_scale[j] : 1.0;
		def->joints[j].offset[0] = model->joints[j].offset.x * s;
		def->joints[j].offset[1] = model->joints[j].offset.y * s;
		def->joints[j].offset[2] = model->joints[j].offset.z * s;
	}
}

static uint64_t take_bytes(const mcd_recorder *r)
{
	uint64_t n = r->poses_file.bytes;
	for (int c = 0; c < r->ncams; c++)
		n += r->cam_files[c].bytes;
	return n;
}

/* ---- starting ---- */

static bool good_name(const char *name)
{
	if (!name[0] || name[0] == '.' || strlen(name) >= TAKE_NAME_MAX)
		return false;
	for (const char *p = name; *p; p++)
		if (!((*p >= 'a' && *p <= 'z') || (*p >= 'A' && *p <= 'Z') || (*p >= '0' && *p <= '9') || *p == '.' ||
		      *p == '_' || *p == '-'))
			return false;
	return true;
}

/* mkdir -p for the [record] directory. */
static int make_dirs(const char *path, mc_err *err)
{
	char p[PATH_MAX];
	snprintf(p, sizeof(p), "%s", path);
	for (char *s = p + 1; *s; s++) {
		if (*s != '/')
			continue;
		*s = 0;
		if (mkdir(p, 0750) < 0 && errno != EEXIST)
			return mc_err_set(err, "%s: %s", p, strerror(errno));
		*s = '/';
	}
	if (mkdir(p, 0750) < 0 && errno != EEXIST)
		return mc_err_set(err, "%s: %s", p, strerror(errno));
	return 0;
}

/* The take's directory from the request: a name in [record] directory or
 * an absolute path; it must not exist. */
static int take_dir(mcd_recorder *r, const char *name, mc_err *err)
{
	char made[TAKE_NAME_MAX];
	if (!name[0]) {
		time_t now = time(NULL);
		struct tm tm;
		localtime_r(&now, &tm);
		strftime(made, sizeof(made), "take-%Y%m%d-%H%M%S", &tm);
		name = made;
	}
	if (name[0] == '/') {
		snprintf(r->dir, sizeof(r->dir), "%s", name);
	} else {
		if (!good_name(name))
			return mc_err_set(err, "'%s': a take name is letters, digits, '.', '_' and '-' (or an absolute path)",
					  name);
		if (make_dirs(r->cfg.directory, err) < 0)
			return mc_err_prefix(err, "[record] directory");
		if (strlen(r->cfg.directory) + 1 + strlen(name) >= sizeof(r->dir))
			return mc_err_set(err, "[record] directory: too long a path");
		snprintf(r->dir, sizeof(r->dir), "%.3000s/%.127s", r->cfg.directory, name);
	}
	if (mkdir(r->dir, 0750) < 0)
		return mc_err_set(err, "%s: %s", r->dir, errno == EEXIST ? "exists already (takes are never overwritten)"
								: strerror(errno));
	const char *base = strrchr(r->dir, '/');
	snprintf(r->info.name, sizeof(r->info.name), "%.127s", base ? base + 1 : r->dir);
	return 0;
}

static int open_files(mcd_recorder *r, mc_err *err)
{
	char path[PATH_MAX + 96];
	for (int c = 0; c < MC_MAX_CAMERAS; c++)
		r->cam_files[c].fd = -1;
	r->poses_file.fd = -1;
	if (r->have_def) {
		snprintf(path, sizeof(path), "%s/poses.mcr", r->dir);
		if (take_file_create(&r->poses_file, path, err) < 0)
			return -1;
		size_t n = take_encode_def(&r->def, r->pose_buf, sizeof(r->pose_buf));
		if (take_file_append(&r->poses_file, TAKE_DEF, r->pose_buf, n, NULL, 0, mc_now_ns(), err) < 0)
			return -1;
	}
	r->info.ncams = r->ncams;
	for (int c = 0; c < r->ncams; c++) {
		snprintf(r->info.cams[c], sizeof(r->info.cams[c]), "%s", mcd_camera_name(r->cams[c]));
		_Static_assert(sizeof(r->info.rig_cams[c]) == sizeof(r->rig_cams[c]), "rig camera names");
		memcpy(r->info.rig_cams[c], r->rig_cams[c], sizeof(r->info.rig_cams[c])); /* NUL-terminated */
		snprintf(path, sizeof(path), "%s/cam-%s.mcr", r->dir, r->info.cams[c]);
		if (r->cfg.frames && take_file_create(&r->cam_files[c], path, err) < 0)
			return -1;
	}
	return 0;
}

static void close_files(mcd_recorder *r)
{
	take_file_close(&r->poses_file);
	for (int c = 0; c < r->ncams; c++)
		take_file_close(&r->cam_files[c]);
}

/* actor.json: the tracker's actor as it is now (its bone scales, head
 * placement and colours: what the take's poses were tracked with), else
 * the config's actor file. */
static int save_actor(mcd_recorder *r, const mc_model *actor, mc_err *err)
{
	char path[PATH_MAX + 16];
	snprintf(path, sizeof(path), "%s/actor.json", r->dir);
	if (!actor)
		return take_copy_file(r->actor, r->dir, "actor.json", err);
	return mc_model_save(actor, path, err);
}

int mcd_recorder_start(mcd_recorder *r, const char *name, const mc_model *actor, char *msg, size_t cap)
{
	mc_err err = {""};
	pthread_mutex_lock(&r->lock);
	if (r->active || r->busy) {
		snprintf(msg, cap, r->active ? "already recording %s" : "the last take %s is still being closed", r->dir);
		pthread_mutex_unlock(&r->lock);
		return -1;
	}
	r->busy = true;
	pthread_mutex_unlock(&r->lock);

	/* The directory and its files: the recorder thread is idle now. */
	memset(&r->info, 0, sizeof(r->info));
	int rc = take_dir(r, name ? name : "", &err);
	if (rc == 0) {
		r->info.start_monotonic_ns = mc_now_ns();
		r->info.start_realtime_ns = mc_realtime_ns();
		r->realtime_offset_ns = (int64_t)(r->info.start_realtime_ns - r->info.start_monotonic_ns);
		rc = open_files(r, &err);
		if (rc == 0)
			rc = take_copy_file(r->config_file, r->dir, "mocapd.conf", &err) ||
			     take_copy_file(r->rig, r->dir, "rig.json", &err) ||
			     take_copy_file(r->model, r->dir, "model.json", &err) ||
			     save_actor(r, actor, &err) || take_info_write(r->dir, &r->info, &err);
		if (rc != 0)
			close_files(r);
	}

	pthread_mutex_lock(&r->lock);
	r->busy = false;
	if (rc != 0) {
		snprintf(msg, cap, "cannot record: %s", err.msg);
	} else {
		r->active = true;
		r->stop_requested = false;
		r->pose_count = r->frame_count = r->head_count = 0; /* nothing from before the start */
		memset(r->queue_drops, 0, sizeof(r->queue_drops));
		r->shown = r->info;
		r->last_seq = 0;
		r->next_sync_ns = mc_now_ns() + (uint64_t)(r->cfg.sync_ms * 1e6);
		snprintf(msg, cap, "recording %s", r->dir);
		mcd_info("record: %s", msg);
	}
	pthread_cond_broadcast(&r->done);
	pthread_mutex_unlock(&r->lock);
	return rc == 0 ? 0 : -1;
}

/* ---- the thread ---- */

/* Ends the take: files synced and closed, take.json final.  Called with
 * the lock held; the file work runs without it (`busy`), so that nobody
 * handing items in waits for the disk. */
static void finish(mcd_recorder *r, const char *reason)
{
	r->active = false;
	r->busy = true;
	for (int c = 0; c < r->ncams; c++)
		r->info.frame_drops[c] += r->queue_drops[c];
	pthread_mutex_unlock(&r->lock);

	mc_err err = {""};
	bool synced = take_file_sync(&r->poses_file, &err) == 0;
	for (int c = 0; c < r->ncams; c++)
		synced = take_file_sync(&r->cam_files[c], &err) == 0 && synced;
	r->info.bytes = take_bytes(r);
	close_files(r);
	r->info.stop_realtime_ns = mc_realtime_ns();
	r->info.complete = true;
	snprintf(r->info.stop_reason, sizeof(r->info.stop_reason), "%s", reason);
	bool written = synced && take_info_write(r->dir, &r->info, &err) == 0;
	double secs = (double)(r->info.stop_realtime_ns - r->info.start_realtime_ns) * 1e-9;

	pthread_mutex_lock(&r->lock);
	snprintf(r->last, sizeof(r->last), "last take %.2048s: %.600s after %.1f s, %llu poses%s%.600s", r->dir, reason, secs,
		 (unsigned long long)r->info.poses, written ? "" : "; take.json not final: ", written ? "" : err.msg);
	r->shown = r->info;
	r->busy = false;
	if (strncmp(reason, "error", 5) == 0)
		mcd_error("record: %s; tracking goes on", r->last);
	else
		mcd_info("record: %s", r->last);
	pthread_cond_broadcast(&r->done);
}

static int write_pose(mcd_recorder *r, queued_pose *q, mc_err *err)
{
	take_pose *p = &q->pose;
	if (!r->have_def)
		return 0;
	uint64_t now = mc_now_ns();
	if (r->last_seq && p->seq > r->last_seq + 1) {
		size_t n = take_encode_gap(r->last_seq + 1, p->seq - r->last_seq - 1, r->pose_buf, sizeof(r->pose_buf));
		if (take_file_append(&r->poses_file, TAKE_GAP, r->pose_buf, n, NULL, 0, now, err) < 0)
			return -1;
		r->info.pose_gaps += p->seq - r->last_seq - 1;
	}
	r->last_seq = p->seq;
	p->realtime_ns = (uint64_t)((int64_t)p->capture_ns + r->realtime_offset_ns);
	size_t n = take_encode_pose(p, r->pose_buf, sizeof(r->pose_buf));
	if (take_file_append(&r->poses_file, TAKE_SKELETON, r->pose_buf, n, NULL, 0, now, err) < 0)
		return -1;
	r->info.poses++;
	if (q->nkp == 0)
		return 0;
	n = take_encode_keypoints(p->seq, p->capture_ns, q->kp, q->nkp, r->pose_buf, sizeof(r->pose_buf));
	return take_file_append(&r->poses_file, TAKE_KEYPOINTS, r->pose_buf, n, NULL, 0, now, err);
}

static int write_frame(mcd_recorder *r, const frame_ref *f, mc_err *err)
{
	int c = f->cam;
	if (r->cam_files[c].fd < 0)
		return 0;
	mc_ring_meta m;
	mc_err rerr;
	int got = mcd_frame_ring_read(mcd_camera_ring(r->cams[c]), f->generation, f->meta.sequence, &r->buf, &r->cap, &m,
				      &rerr);
	if (got != MC_RING_FRAME) { /* overwritten before we got to it */
		r->info.frame_drops[c]++;
		return 0;
	}
	take_frame_meta tm = {
		.sequence = m.sequence,
		.capture_ns = m.timestamp_ns,
		.realtime_ns = (uint64_t)((int64_t)m.timestamp_ns + r->realtime_offset_ns),
		.driver_sequence = m.driver_sequence,
		.pixfmt = m.pixfmt,
		.width = m.width,
		.height = m.height,
		.stride = m.stride,
		.flags = m.flags,
	};
	uint8_t head[TAKE_FRAME_META_SIZE];
	take_encode_frame_meta(&tm, head);
	if (take_file_append(&r->cam_files[c], TAKE_FRAME, head, sizeof(head), r->buf, (size_t)m.bytesused, mc_now_ns(),
			     err) < 0)
		return -1;
	r->info.frames[c]++;
	return 0;
}

static int write_head_pose(mcd_recorder *r, const take_head_pose *h, mc_err *err)
{
	if (r->poses_file.fd < 0)
		return 0;
	uint8_t buf[TAKE_HEAD_POSE_SIZE];
	take_encode_head_pose(h, buf);
	return take_file_append(&r->poses_file, TAKE_HEAD_POSE, buf, sizeof(buf), NULL, 0, mc_now_ns(), err);
}

/* Limits and the periodic sync; a reason to stop, or NULL. */
static const char *due(mcd_recorder *r, char *why, size_t cap, mc_err *err)
{
	uint64_t now = mc_now_ns();
	if (now >= r->next_sync_ns) {
		r->next_sync_ns = now + (uint64_t)(r->cfg.sync_ms * 1e6);
		if (take_file_sync(&r->poses_file, err) < 0)
			return NULL;
		for (int c = 0; c < r->ncams; c++)
			if (take_file_sync(&r->cam_files[c], err) < 0)
				return NULL;
	}
	double secs = (double)(now - r->info.start_monotonic_ns) * 1e-9;
	if (r->cfg.max_seconds > 0 && secs >= r->cfg.max_seconds) {
		snprintf(why, cap, "limit: [record] max_seconds = %g reached", r->cfg.max_seconds);
		return why;
	}
	if (r->cfg.max_mb > 0 && (double)take_bytes(r) >= r->cfg.max_mb * 1e6) {
		snprintf(why, cap, "limit: [record] max_mb = %g reached", r->cfg.max_mb);
		return why;
	}
	return NULL;
}

/* Takes one queued item (head poses and skeletons first: they are small
 * and what labs need most) into *head, *pose or *frame; 3 head pose, 1
 * pose, 2 frame, 0 none.  Under lock. */
static int pop(mcd_recorder *r, take_head_pose *head, queued_pose *pose, frame_ref *frame)
{
	if (r->head_count) {
		*head = r->heads[r->head_head];
		r->head_head = (r->head_head + 1) % HEAD_QUEUE;
		r->head_count--;
		return 3;
	}
	if (r->pose_count) {
		*pose = r->poses[r->pose_head];
		r->pose_head = (r->pose_head + 1) % POSE_QUEUE;
		r->pose_count--;
		return 1;
	}
	if (r->frame_count) {
		*frame = r->frames[r->frame_head];
		r->frame_head = (r->frame_head + 1) % FRAME_QUEUE;
		r->frame_count--;
		return 2;
	}
	return 0;
}

static void *recorder_main(void *arg)
{
	mcd_recorder *r = arg;
	static queued_pose pose; /* one recorder per process */
	frame_ref frame;
	take_head_pose head;
	mc_thread_set_name("mocapd-record");
	pthread_mutex_lock(&r->lock);
	while (!r->quit || r->active) { /* a take in progress is drained and finished first */
		int what = r->active ? pop(r, &head, &pose, &frame) : 0;
		if (!what) {
			if (r->active && (r->stop_requested || r->quit)) {
				finish(r, r->quit ? "stopped: mocapd is stopping" : "stopped by request");
				continue;
			}
			if (r->quit)
				break;
			struct timespec until = mc_cond_deadline(50 * MC_NS_PER_MS);
			pthread_cond_timedwait(&r->wake, &r->lock, &until);
		}
		if (!r->active)
			continue;
		/* Files are the thread's: write without the lock. */
		pthread_mutex_unlock(&r->lock);
		mc_err err = {""};
		char why[160];
		int rc = what == 1   ? write_pose(r, &pose, &err)
			 : what == 2 ? write_frame(r, &frame, &err)
			 : what == 3 ? write_head_pose(r, &head, &err)
				     : 0;
		const char *stop = rc == 0 ? due(r, why, sizeof(why), &err) : NULL;
		r->info.bytes = take_bytes(r);
		pthread_mutex_lock(&r->lock);
		r->shown = r->info; /* the counts, for status */
		if (rc < 0 || err.msg[0]) {
			char reason[600];
			snprintf(reason, sizeof(reason), "error: %s", err.msg);
			finish(r, reason);
		} else if (stop)
			finish(r, stop);
	}
	pthread_mutex_unlock(&r->lock);
	return NULL;
}

/* ---- from the other threads ---- */

void mcd_recorder_push_frame(mcd_recorder *r, int cam, uint64_t generation, const mc_ring_meta *meta)
{
	if (!r || !r->cfg.frames)
		return;
	pthread_mutex_lock(&r->lock);
	if (r->active && !r->stop_requested && !r->quit) {
		if (r->frame_count == FRAME_QUEUE)
			r->queue_drops[cam]++;
		else {
			r->frames[(r->frame_head + r->frame_count++) % FRAME_QUEUE] = (frame_ref){cam, generation, *meta};
			pthread_cond_signal(&r->wake);
		}
	}
	pthread_mutex_unlock(&r->lock);
}

void mcd_recorder_push_head_pose(void *ctx, const mc_pose *hp)
{
	mcd_recorder *r = ctx;
	pthread_mutex_lock(&r->lock);
	if (r->active && !r->stop_requested && !r->quit) {
		if (r->head_count == HEAD_QUEUE)
			r->head_drops++;
		else {
			take_head_pose *h = &r->heads[(r->head_head + r->head_count++) % HEAD_QUEUE];
			*h = (take_head_pose){hp->timestamp_ns,
					      {hp->position.x, hp->position.y, hp->position.z},
					      {hp->orientation.w, hp->orientation.x, hp->orientation.y, hp->orientation.z}};
			pthread_cond_signal(&r->wake);
		}
	}
	pthread_mutex_unlock(&r->lock);
}

void mcd_recorder_push_pose(mcd_recorder *r, const mcd_output *o, uint64_t seq)
{
	if (!r || !r->have_def || !o->tracked)
		return;
	pthread_mutex_lock(&r->lock);
	/* A full queue drops the pose: the gap shows in the take. */
	if (r->active && !r->stop_requested && !r->quit && r->pose_count < POSE_QUEUE) {
		queued_pose *q = &r->poses[(r->pose_head + r->pose_count++) % POSE_QUEUE];
		take_pose *p = &q->pose;
		q->nkp = o->nkp > 0 && o->nkp <= MCD_OUTPUT_KEYPOINTS ? o->nkp : 0;
		for (int k = 0; k < q->nkp; k++)
			q->kp[k] = (take_keypoint){(uint16_t)o->kp[k].cam, (uint16_t)o->kp[k].joint, (float)o->kp[k].u,
						   (float)o->kp[k].v, (float)o->kp[k].conf};
		p->seq = seq;
		p->capture_ns = o->timestamp_ns;
		p->state = (int)o->sk.state;
		p->def_id = r->def.id;
		p->njoints = o->sk.njoints < TAKE_MAX_JOINTS ? o->sk.njoints : TAKE_MAX_JOINTS;
		p->ndof = o->ndof > 0 && o->ndof <= TAKE_MAX_DOF ? o->ndof : 0;
		memcpy(p->dofs, o->pose, sizeof(double) * (size_t)p->ndof);
		for (int j = 0; j < p->njoints; j++) {
			const mc_skeleton_joint *s = &o->sk.joints[j];
			take_joint *t = &p->joints[j];
			t->position[0] = s->position.x;
			t->position[1] = s->position.y;
			t->position[2] = s->position.z;
			t->orientation[0] = s->orientation.w;
			t->orientation[1] = s->orientation.x;
			t->orientation[2] = s->orientation.y;
			t->orientation[3] = s->orientation.z;
			t->confidence = s->confidence;
		}
		pthread_cond_signal(&r->wake);
	}
	pthread_mutex_unlock(&r->lock);
}

/* ---- main thread ---- */

int mcd_recorder_stop(mcd_recorder *r, char *msg, size_t cap)
{
	pthread_mutex_lock(&r->lock);
	while (r->busy && !r->active) /* a take ending (an error, a limit) or starting */
		pthread_cond_wait(&r->done, &r->lock);
	if (!r->active) {
		snprintf(msg, cap, "not recording");
		pthread_mutex_unlock(&r->lock);
		return -1;
	}
	r->stop_requested = true;
	pthread_cond_signal(&r->wake);
	while (r->active || r->busy)
		pthread_cond_wait(&r->done, &r->lock);
	snprintf(msg, cap, "%s", r->last);
	pthread_mutex_unlock(&r->lock);
	return 0;
}

bool mcd_recorder_active(mcd_recorder *r)
{
	if (!r)
		return false;
	pthread_mutex_lock(&r->lock);
	bool a = r->active;
	pthread_mutex_unlock(&r->lock);
	return a;
}

void mcd_recorder_status(mcd_recorder *r, char *msg, size_t cap)
{
	pthread_mutex_lock(&r->lock);
	if (r->active) {
		const take_info *i = &r->shown;
		uint64_t frames = 0, drops = 0, bytes = 0;
		for (int c = 0; c < r->ncams; c++) {
			frames += i->frames[c];
			drops += i->frame_drops[c] + r->queue_drops[c];
		}
		bytes = i->bytes;
		snprintf(msg, cap, "recording %s: %.1f s, %llu poses (%llu missed), %llu frames (%llu dropped), %.1f MB",
			 r->dir, (double)(mc_now_ns() - i->start_monotonic_ns) * 1e-9, (unsigned long long)i->poses,
			 (unsigned long long)i->pose_gaps, (unsigned long long)frames, (unsigned long long)drops,
			 (double)bytes * 1e-6);
	} else if (r->busy) {
		snprintf(msg, cap, "opening or closing the take %s", r->dir);
	} else
		snprintf(msg, cap, "not recording%s%s%s", r->last[0] ? " (" : "", r->last, r->last[0] ? ")" : "");
	pthread_mutex_unlock(&r->lock);
}

const char *mcd_recorder_directory(const mcd_recorder *r)
{
	return r->cfg.directory;
}

mcd_recorder *mcd_recorder_create(const mcd_recorder_setup *s, mc_err *err)
{
	mcd_recorder *r = calloc(1, sizeof(*r));
	if (!r || !(r->poses = calloc(POSE_QUEUE, sizeof(queued_pose)))) {
		free(r);
		mc_err_set(err, "out of memory");
		return NULL;
	}
	r->cfg = *s->cfg;
	snprintf(r->config_file, sizeof(r->config_file), "%s", s->daemon_cfg->file);
	snprintf(r->rig, sizeof(r->rig), "%s", s->daemon_cfg->tracker.rig);
	snprintf(r->model, sizeof(r->model), "%s", s->daemon_cfg->tracker.model);
	snprintf(r->actor, sizeof(r->actor), "%s", s->daemon_cfg->tracker.actor);
	r->ncams = s->ncams;
	for (int c = 0; c < s->ncams; c++) {
		r->cams[c] = s->cams[c];
		snprintf(r->rig_cams[c], sizeof(r->rig_cams[c]), "%s", s->daemon_cfg->cams[c].rig_camera);
	}
	if (s->model) {
		def_from_model(s->model, 1, &r->def);
		r->have_def = true;
	}
	r->poses_file.fd = -1;
	for (int c = 0; c < MC_MAX_CAMERAS; c++)
		r->cam_files[c].fd = -1;
	pthread_mutex_init(&r->lock, NULL);
	mc_cond_init_monotonic(&r->wake);
	pthread_cond_init(&r->done, NULL);
	if (pthread_create(&r->thread, NULL, recorder_main, r) != 0) {
		mc_err_set(err, "recorder thread: %s", strerror(errno));
		mcd_recorder_destroy(r);
		return NULL;
	}
	r->thread_started = true;
	return r;
}

void mcd_recorder_destroy(mcd_recorder *r)
{
	if (!r)
		return;
	if (r->thread_started) {
		pthread_mutex_lock(&r->lock);
		r->quit = true;
		pthread_cond_signal(&r->wake);
		pthread_mutex_unlock(&r->lock);
		pthread_join(r->thread, NULL);
	}
	pthread_cond_destroy(&r->done);
	pthread_cond_destroy(&r->wake);
	pthread_mutex_destroy(&r->lock);
	free(r->buf);
	free(r->poses);
	free(r);
}
