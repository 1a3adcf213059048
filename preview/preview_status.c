/* preview_status: event JSON for the page (preview_status.h). */
#include "preview_status.h"

#include <jansson.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

void history_add_skeleton(preview_history *h, const mocap_skeleton_frame *f)
{
	if (f->njoints <= 0)
		return;
	double sum = 0;
	for (int j = 0; j < f->njoints; j++)
		sum += f->joints[j].confidence;
	h->conf_sum += sum / f->njoints;
	h->conf_n++;
}

void history_close_second(preview_history *h, double t, double track_ms)
{
	int i = (h->head + h->n) % HISTORY_SECONDS;
	if (h->n == HISTORY_SECONDS)
		h->head = (h->head + 1) % HISTORY_SECONDS;
	else
		h->n++;
	h->t[i] = t;
	h->track_ms[i] = track_ms;
	h->confidence[i] = h->conf_n ? h->conf_sum / (double)h->conf_n : NAN;
	h->conf_sum = 0;
	h->conf_n = 0;
}

/* A number, or null for NAN (JSON has no NaN). */
static json_t *number(double v)
{
	return isfinite(v) ? json_real(v) : json_null();
}

static char *dump(json_t *o)
{
	char *s = o ? json_dumps(o, JSON_COMPACT) : NULL;
	json_decref(o);
	return s;
}

static json_t *history_json(const preview_history *h)
{
	json_t *t = json_array(), *ms = json_array(), *conf = json_array();
	for (int k = 0; h && k < h->n; k++) {
		int i = (h->head + k) % HISTORY_SECONDS;
		json_array_append_new(t, json_real(h->t[i]));
		json_array_append_new(ms, number(h->track_ms[i]));
		json_array_append_new(conf, number(h->confidence[i]));
	}
	return json_pack("{s:o, s:o, s:o}", "t", t, "track_ms", ms, "confidence", conf);
}

static const char *cam_state(int s)
{
	static const char *names[] = {"ok", "stalled", "error", "off"};
	return s >= 0 && s < 4 ? names[s] : "unknown";
}

static json_t *cameras_json(const mocap_daemon_status *st)
{
	json_t *a = json_array();
	for (int i = 0; i < st->ncams && i < MOCAP_MAX_CAMERAS; i++) {
		const mocap_camera_status *c = &st->cams[i];
		json_array_append_new(a, json_pack("{s:s, s:s, s:i, s:i, s:o, s:I, s:I}", "name", c->name, "state",
						   cam_state(c->state), "width", c->width, "height", c->height, "fps",
						   number(c->fps), "frames", (json_int_t)c->frames, "drops",
						   (json_int_t)c->drops));
	}
	return a;
}

static json_t *daemon_json(const mocap_daemon_status *st)
{
	const mocap_latency_status *l = &st->latency;
	json_t *o = json_pack("{s:s, s:b, s:o, s:o, s:o, s:I, s:I, s:i, s:s, s:f, s:o}", "tracker",
			      mocap_track_state_name(st->tracker_state), "recording", st->recording, "publish_fps",
			      number(st->publish_fps), "track_ms_mean", number(st->track_ms_mean), "track_ms_max",
			      number(st->track_ms_max), "frames_published", (json_int_t)st->frames_published,
			      "frames_dropped", (json_int_t)st->frames_dropped, "clients", st->clients, "device",
			      st->device, "uptime_s", (double)st->uptime_ns * 1e-9, "cameras", cameras_json(st));
	if (o && l->known)
		json_object_set_new(o, "track_ms_p99", number(l->stage[MOCAP_LAT_TRACK].p99));
	return o;
}

char *status_json(const preview_status_in *in)
{
	json_t *o = json_pack("{s:b, s:s, s:s, s:s, s:b, s:o}", "connected", in->st != NULL, "socket",
			      in->socket ? in->socket : "", "message", in->message ? in->message : "", "record",
			      in->record_msg ? in->record_msg : "", "can_record", in->can_record, "history",
			      history_json(in->history));
	if (o && in->st)
		json_object_set_new(o, "daemon", daemon_json(in->st));
	return dump(o);
}

char *skeleton_json(const mocap_skeleton_def *def, const mocap_skeleton_frame *f)
{
	json_t *joints = json_array();
	bool named = def && def->id == f->skeleton_id && def->njoints == f->njoints;
	for (int j = 0; j < f->njoints; j++) {
		const mocap_joint *jt = &f->joints[j];
		json_array_append_new(joints, json_pack("{s:s, s:i, s:[f,f,f], s:f}", "name",
							named ? def->joints[j].name : "", "parent",
							named ? def->joints[j].parent : -1, "p", jt->position[0],
							jt->position[1], jt->position[2], "c", (double)jt->confidence));
	}
	return dump(json_pack("{s:I, s:s, s:s, s:b, s:o}", "seq", (json_int_t)f->seq, "state",
			      mocap_track_state_name(f->state), "space", f->space == MOCAP_SPACE_WORLD ? "world" : "rig",
			      "rig_is_world", def ? def->rig_is_world : 0, "joints", joints));
}

char *frame_json(int camera, const char *name, int width, int height, uint64_t seq, const uint8_t *jpeg,
		 size_t bytes)
{
	char *b64 = base64_encode(jpeg, bytes);
	if (!b64)
		return NULL;
	char *s = dump(json_pack("{s:i, s:s, s:i, s:i, s:I, s:s}", "camera", camera, "name", name, "width", width,
				 "height", height, "seq", (json_int_t)seq, "jpeg", b64));
	free(b64);
	return s;
}

char *base64_encode(const uint8_t *data, size_t n)
{
	static const char abc[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
	char *out = malloc((n + 2) / 3 * 4 + 1), *p = out;
	if (!out)
		return NULL;
	for (size_t i = 0; i < n; i += 3) {
		uint32_t v = (uint32_t)data[i] << 16 | (i + 1 < n ? (uint32_t)data[i + 1] << 8 : 0) |
			     (i + 2 < n ? data[i + 2] : 0);
		*p++ = abc[v >> 18 & 63];
		*p++ = abc[v >> 12 & 63];
		*p++ = i + 1 < n ? abc[v >> 6 & 63] : '=';
		*p++ = i + 2 < n ? abc[v & 63] : '=';
	}
	*p = 0;
	return out;
}
