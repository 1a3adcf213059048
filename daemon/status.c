#include "status.h"

#include "textbuf.h"

#include <stdio.h>
#include <string.h>

uint64_t mcd_cam_drops(const mcd_cam_status *c)
{
	return c->counters.short_frames + c->counters.corrupt_frames + c->counters.bad_frames + c->counters.nospace +
	       c->counters.lost +
	       c->track.overrun + c->track.undecodable + c->track.late;
}

static double rate(uint64_t now, uint64_t prev, double dt_s)
{
	return dt_s > 0 && now >= prev ? (double)(now - prev) / dt_s : 0;
}

/* Mean tracking time over the interval. */
static double mean_track_ms(const mcd_pipeline_status *now, const mcd_pipeline_status *prev)
{
	uint64_t n = now->track.tracked - prev->track.tracked;
	return n ? (now->track.track_ms_total - prev->track.track_ms_total) / (double)n : 0;
}

static const char *track_state_name(int s)
{
	return s < 0 ? "idle" : mc_track_state_name((mc_track_state)s);
}

/* Mean ms per view over the interval (the last view's if none was detected in it). */
static double mean_detect_ms(const mcd_detector_stats *now, const mcd_detector_stats *prev)
{
	uint64_t n = now->detections - prev->detections;
	return n ? (now->ms_total - prev->ms_total) / (double)n : now->ms_last;
}

/* " | detector 59.8 views/s, 1.05 ms per view (max 1.90), 58.0 used/s, 0 skipped" */
static void detector_line(const mcd_pipeline_status *now, const mcd_pipeline_status *prev, double dt_s, char *buf,
			  size_t cap, size_t *len)
{
	const mcd_detector_stats *d = &now->detector, *p = &prev->detector;
	if (d->state == MCD_DETECTOR_FAILED)
		mcd_appendf(buf, cap, len, " | detector failed (%s)", d->message);
	if (d->state != MCD_DETECTOR_RUNNING)
		return;
	mcd_appendf(buf, cap, len, " | detector %.1f views/s, %.2f ms per view (max %.2f), %.1f used/s, %llu skipped",
		    rate(d->detections, p->detections, dt_s), mean_detect_ms(d, p), d->ms_max,
		    rate(now->track.detector_views, prev->track.detector_views, dt_s),
		    (unsigned long long)d->skipped);
	if (d->one_look > 0) /* [detector] hint = pose */
		mcd_appendf(buf, cap, len, ", one look in %llu of %llu views",
			    (unsigned long long)d->one_look, (unsigned long long)d->detections);
}

void mcd_status_line(const mcd_pipeline_status *now, const mcd_pipeline_status *prev, double dt_s, char *buf,
		     size_t cap)
{
	size_t len = 0;
	if (cap)
		buf[0] = 0;
	if (now->tracking)
		mcd_appendf(buf, cap, &len, "tracking %.1f fps, %.1f ms (max %.1f), %s",
			    rate(now->track.tracked, prev->track.tracked, dt_s), mean_track_ms(now, prev),
			    now->track.track_ms_max, track_state_name(now->track.track_state));
	else
		mcd_appendf(buf, cap, &len, "tracker off, %.1f frame sets/s", rate(now->track.sets, prev->track.sets, dt_s));
	const srv_latency_status *l = &now->latency;
	if (l->window)
		mcd_appendf(buf, cap, &len, ", capture to publish %.1f ms (p99 %.1f)", l->stage[SRV_LAT_TOTAL].p50,
			    l->stage[SRV_LAT_TOTAL].p99);
	if (l->skipped_stale)
		mcd_appendf(buf, cap, &len, ", %llu stale sets skipped", (unsigned long long)l->skipped_stale);
	detector_line(now, prev, dt_s, buf, cap, &len);
	for (int c = 0; c < now->ncams; c++) {
		const mcd_cam_status *cn = &now->cams[c], *cp = &prev->cams[c];
		mcd_appendf(buf, cap, &len, " | %s: %s", cn->name, mcd_cam_state_name(cn->state));
		if (cn->state == MCD_CAM_STREAMING || cn->state == MCD_CAM_STALLED)
			mcd_appendf(buf, cap, &len, " %.1f fps, %llu drops",
				    rate(cn->counters.frames, cp->counters.frames, dt_s), (unsigned long long)mcd_cam_drops(cn));
		else if (cn->last_error[0])
			mcd_appendf(buf, cap, &len, " (%s)", cn->last_error);
	}
}

static srv_cam_state server_cam_state(const mcd_cam_status *c)
{
	switch (c->state) {
	case MCD_CAM_STREAMING:
		return MC_CAM_STATE_OK;
	case MCD_CAM_STALLED:
		return MC_CAM_STATE_STALLED;
	case MCD_CAM_RETRYING:
		return MC_CAM_STATE_ERROR;
	case MCD_CAM_FAILED: /* the log's word too */
		return MC_CAM_STATE_FAILED;
	case MCD_CAM_OPENING:
		return c->counters.errors ? MC_CAM_STATE_ERROR : MC_CAM_STATE_OFF;
	default:
		return MC_CAM_STATE_OFF;
	}
}

static void detector_to_server(const mcd_pipeline_status *now, const mcd_pipeline_status *prev, double dt_s,
			       srv_detector_status *o)
{
	const mcd_detector_stats *d = &now->detector;
	o->state = (srv_detector_state)d->state;
	o->rate = rate(d->detections, prev->detector.detections, dt_s);
	o->used_rate = rate(now->track.detector_views, prev->track.detector_views, dt_s);
	o->ms_mean = mean_detect_ms(d, &prev->detector);
	o->ms_last = d->ms_last;
	o->ms_max = d->ms_max;
	o->views = d->detections;
	o->skipped = d->skipped;
	o->used = now->track.detector_views;
	snprintf(o->model, sizeof(o->model), "%s", d->model);
	snprintf(o->message, sizeof(o->message), "%s", d->message);
}

void mcd_status_to_server(const mcd_pipeline_status *now, const mcd_pipeline_status *prev, double dt_s,
			  uint64_t start_ns, const char *device, srv_status *out)
{
	memset(out, 0, sizeof(*out));
	out->tracker_state = now->tracking && now->track.track_state >= 0 ? (srv_tracker_state)now->track.track_state
									   : SRV_TRACKER_IDLE;
	out->publish_fps = rate(now->publish.published, prev->publish.published, dt_s);
	out->track_ms_mean = mean_track_ms(now, prev);
	out->track_ms_max = now->track.track_ms_max;
	out->frames_published = now->publish.published;
	out->frames_dropped = now->track.skipped + now->track.stale + now->publish.dropped;
	out->start_ns = start_ns;
	snprintf(out->device, sizeof(out->device), "%s", device ? device : "");
	out->ncams = now->ncams < MC_MAX_CAMERAS ? now->ncams : MC_MAX_CAMERAS;
	for (int c = 0; c < out->ncams; c++) {
		const mcd_cam_status *cn = &now->cams[c];
		srv_cam_status *o = &out->cams[c];
		snprintf(o->name, sizeof(o->name), "%s", cn->name);
		o->state = server_cam_state(cn);
		o->width = (int)cn->format.width;
		o->height = (int)cn->format.height;
		o->fps = rate(cn->counters.frames, prev->cams[c].counters.frames, dt_s);
		o->frames = cn->counters.frames;
		o->drops = mcd_cam_drops(cn);
	}
	detector_to_server(now, prev, dt_s, &out->detector);
	out->latency = now->latency;
}
