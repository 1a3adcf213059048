/* preview_link: the daemon connection of mocap-preview (preview_link.h). */
#include "preview_link.h"

#include "base/mc_time.h"
#include "geom/mc_rig.h"
#include "mocap.h"
#include "preview_render.h"
#include "preview_status.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* A camera seen through its ring. */
typedef struct {
	char name[MOCAP_NAME_MAX];
	mc_ring *ring;
	mc_ring_cursor cursor;
	int rig_index; /* -1: no calibration, the frame without overlay */
	uint8_t *buf;
	size_t cap;
	uint64_t sent;
} camera;

typedef struct {
	const link_config *cfg;
	mocap_client *c;
	bool privileged;
	mocap_skeleton_def def;
	bool have_def;
	mc_rig rig;
	bool have_rig;
	camera cams[MOCAP_MAX_RINGS];
	int ncams;
	mocap_skeleton_frame frame; /* the newest */
	bool have_frame;
	preview_history history;
	preview_renderer *render;
	uint64_t start_ns, last_ring_frame_ns;
	char message[512];
} link_state;

static void close_rings(link_state *s)
{
	for (int i = 0; i < s->ncams; i++) {
		mc_ring_close(s->cams[i].ring);
		free(s->cams[i].buf);
	}
	memset(s->cams, 0, sizeof(s->cams));
	s->ncams = 0;
}

/* The rig (for projecting) and the rings (read-only maps).  Rings need the
 * daemon's user or group: without them the page has no camera views. */
static void open_cameras(link_state *s)
{
	close_rings(s);
	char *json = NULL;
	int n = 0;
	mc_err err = {""};
	s->have_rig = mocap_get_rig(s->c, &json, &n) == 0 && mc_rig_parse(json, "the daemon's rig", &s->rig, &err) == 0;
	free(json);
	if (!s->privileged)
		return;
	mocap_ring rings[MOCAP_MAX_RINGS];
	int nr = mocap_get_rings(s->c, rings, MOCAP_MAX_RINGS);
	for (int i = 0; i < nr; i++) {
		camera *cam = &s->cams[s->ncams];
		cam->ring = mc_ring_map(rings[i].fd, &err);
		close(rings[i].fd);
		if (!cam->ring) {
			fprintf(stderr, "mocap-preview: camera %s: cannot map its ring: %s\n", rings[i].camera, err.msg);
			continue;
		}
		snprintf(cam->name, sizeof(cam->name), "%.*s", MOCAP_NAME_MAX - 1, rings[i].camera);
		cam->cursor = mc_ring_cursor_now(cam->ring);
		cam->cap = mc_ring_slot_bytes(cam->ring);
		cam->buf = malloc(cam->cap);
		/* The ring is named after the camera, the rig's camera usually
		 * the same; else ring i is rig camera i (as mocap-detect). */
		cam->rig_index = s->have_rig ? mc_rig_find(&s->rig, cam->name) : -1;
		if (cam->rig_index < 0 && s->have_rig && i < s->rig.ncams)
			cam->rig_index = i;
		if (!cam->buf) {
			mc_ring_close(cam->ring);
			continue;
		}
		s->ncams++;
	}
	s->last_ring_frame_ns = mc_now_ns();
}

static void disconnect(link_state *s)
{
	close_rings(s);
	if (s->c)
		mocap_close(s->c);
	s->c = NULL;
	s->have_def = s->have_frame = false;
}

static void post_status(link_state *s, const mocap_daemon_status *st)
{
	char record[1024] = "";
	if (st && s->privileged)
		mocap_control(s->c, MOCAP_CMD_RECORD_STATUS, NULL, record, sizeof(record));
	preview_status_in in = {.st = st,
				.socket = s->cfg->socket ? s->cfg->socket : mocap_default_socket(),
				.message = s->message,
				.record_msg = record,
				.can_record = st && s->privileged,
				.history = &s->history};
	char *json = status_json(&in);
	if (json)
		hub_post(s->cfg->hub, SLOT_STATUS, "status", json);
	free(json);
}

/* Says a new state of the connection once (stderr and the page). */
static void set_message(link_state *s, const char *fmt, const char *detail)
{
	char msg[512];
	snprintf(msg, sizeof(msg), fmt, detail);
	if (strcmp(msg, s->message) != 0)
		fprintf(stderr, "mocap-preview: %s\n", msg);
	snprintf(s->message, sizeof(s->message), "%s", msg);
}

static bool connect_daemon(link_state *s)
{
	const char *path = s->cfg->socket ? s->cfg->socket : mocap_default_socket();
	s->c = mocap_connect(s->cfg->socket, "mocap-preview");
	if (!s->c) {
		char why[400];
		snprintf(why, sizeof(why), "%.380s", mocap_errmsg());
		set_message(s, "waiting for mocapd (%s); trying again every second", why);
		return false;
	}
	if (mocap_subscribe(s->c, MOCAP_LATEST, MOCAP_SPACE_RIG, 0) < 0) {
		set_message(s, "mocapd: cannot subscribe: %s", mocap_errmsg());
		disconnect(s);
		return false;
	}
	s->privileged = mocap_is_privileged(s->c);
	set_message(s, s->privileged ? "connected to mocapd at %s"
				     : "connected to mocapd at %s; no camera views or recording: they need the daemon's "
				       "user or group",
		    path);
	return true;
}

/* A new frame: the definition (again after a reload changed it). */
static int take_frame(link_state *s, const mocap_skeleton_frame *f)
{
	if (!s->have_def || s->def.id != f->skeleton_id) {
		if (mocap_get_skeleton(s->c, &s->def) < 0)
			return -1;
		s->have_def = true;
		open_cameras(s); /* a reload may have changed the rig and cameras */
	}
	s->frame = *f;
	s->have_frame = true;
	history_add_skeleton(&s->history, f);
	return 0;
}

static void post_skeleton(link_state *s)
{
	char *json = skeleton_json(s->have_def ? &s->def : NULL, &s->frame);
	if (json)
		hub_post(s->cfg->hub, SLOT_SKELETON, "skeleton", json);
	free(json);
}

/* Each camera's newest frame, drawn over and posted. */
static void post_frames(link_state *s)
{
	static preview_overlay ov; /* 10 KB: not on the stack; this thread only */
	bool overlay = s->have_frame && s->have_def && s->frame.state != MOCAP_TRACK_LOST;
	if (overlay)
		preview_overlay_set(&ov, &s->def, &s->frame, s->cfg->model);
	bool any = false;
	for (int i = 0; i < s->ncams; i++) {
		camera *cam = &s->cams[i];
		mc_ring_meta meta;
		mc_err err = {""};
		int rc = mc_ring_read_latest(cam->ring, &cam->cursor, cam->buf, cam->cap, &meta, &err);
		if (rc != MC_RING_FRAME)
			continue;
		any = true;
		uint8_t *jpeg = NULL;
		size_t bytes = 0;
		int w, h;
		const mc_camera *rc_cam = cam->rig_index >= 0 ? &s->rig.cams[cam->rig_index] : NULL;
		if (render_frame(s->render, &meta, cam->buf, rc_cam, overlay ? &ov : NULL, &jpeg, &bytes, &w, &h, &err) < 0) {
			fprintf(stderr, "mocap-preview: camera %s: %s\n", cam->name, err.msg);
			continue;
		}
		char *json = frame_json(i, cam->name, w, h, ++cam->sent, jpeg, bytes);
		if (json)
			hub_post(s->cfg->hub, SLOT_FRAME0 + i, "frame", json);
		free(json);
		free(jpeg);
	}
	uint64_t now = mc_now_ns();
	if (any)
		s->last_ring_frame_ns = now;
	else if (s->ncams > 0 && now - s->last_ring_frame_ns > 3 * MC_NS_PER_S) {
		/* The daemon reopened the cameras with new rings, maybe. */
		open_cameras(s);
	}
}

static uint64_t min_u64(uint64_t a, uint64_t b) { return a < b ? a : b; }

/* Connected: frames, status, views until the daemon goes away.  Sleeps
 * in mocap_read_frame until a skeleton comes or the next status, view or
 * held-back skeleton is due: never spins. */
static void serve(link_state *s)
{
	const link_config *cfg = s->cfg;
	const uint64_t frame_period = (uint64_t)(1e9 / cfg->rate), skeleton_period = MC_NS_PER_S / 20;
	uint64_t now = mc_now_ns(), next_status = now, next_frames = now, next_skeleton = now;
	bool skeleton_held = false; /* a skeleton came sooner than skeleton_period after the last one */
	static mocap_skeleton_frame f; /* 9 KB: not on the stack */
	while (!*cfg->stop) {
		now = mc_now_ns();
		bool readers = hub_readers(cfg->hub) > 0;
		uint64_t due = next_status;
		if (readers)
			due = min_u64(due, skeleton_held ? min_u64(next_frames, next_skeleton) : next_frames);
		int wait_ms = due > now ? (int)((due - now + MC_NS_PER_MS - 1) / MC_NS_PER_MS) : 0;
		int rc = mocap_read_frame(s->c, &f, wait_ms > 200 ? 200 : wait_ms);
		if (rc < 0 || (rc == 1 && take_frame(s, &f) < 0)) {
			set_message(s, "lost mocapd: %s; connecting again", mocap_errmsg());
			return;
		}
		now = mc_now_ns();
		if (now >= next_status || atomic_exchange(cfg->status_now, 0)) {
			static mocap_daemon_status st;
			if (mocap_get_status(s->c, &st) < 0) {
				set_message(s, "lost mocapd: %s; connecting again", mocap_errmsg());
				return;
			}
			if (now >= next_status) {
				history_close_second(&s->history, (double)(now - s->start_ns) * 1e-9, st.track_ms_mean);
				next_status += MC_NS_PER_S * (1 + (now - next_status) / MC_NS_PER_S);
			}
			post_status(s, &st);
		}
		skeleton_held |= rc == 1;
		if (!readers)
			skeleton_held = false;
		if (skeleton_held && now >= next_skeleton) {
			post_skeleton(s);
			skeleton_held = false;
			next_skeleton = now + skeleton_period;
		}
		if (readers && now >= next_frames) {
			post_frames(s);
			next_frames += frame_period * (1 + (now - next_frames) / frame_period);
		}
	}
}

void link_run(const link_config *cfg)
{
	static link_state s; /* large (rig, definitions): not on the stack */
	memset(&s, 0, sizeof(s));
	s.cfg = cfg;
	s.start_ns = mc_now_ns();
	mc_err err = {""};
	s.render = render_new(cfg->width, cfg->quality, &err);
	if (!s.render) {
		fprintf(stderr, "mocap-preview: %s\n", err.msg);
		return;
	}
	uint64_t next_try = 0;
	while (!*cfg->stop) {
		if (mc_now_ns() < next_try) {
			usleep(50000);
			continue;
		}
		next_try = mc_now_ns() + MC_NS_PER_S;
		if (!connect_daemon(&s)) {
			history_close_second(&s.history, (double)(mc_now_ns() - s.start_ns) * 1e-9, NAN);
			post_status(&s, NULL);
			continue;
		}
		serve(&s);
		disconnect(&s);
		post_status(&s, NULL);
	}
	disconnect(&s);
	render_free(s.render);
}
