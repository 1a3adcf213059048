#include "lockstep.h"

#include "log.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

/* Drivers of live cameras (the others play recordings). */
static bool live_driver(const char *driver)
{
	static const char *const live[] = {"v4l2", "usb", "aravis", "libcamera", "openni2"};
	for (size_t i = 0; i < sizeof(live) / sizeof(live[0]); i++)
		if (strcmp(driver, live[i]) == 0)
			return true;
	return false;
}

/* The camera's value of a driver key, and its line; NULL if not given. */
static const char *driver_key(const mcd_camera_config *cam, const char *key, int *line)
{
	for (int i = 0; i < cam->nkeys; i++)
		if (strcmp(cam->keys[i].key, key) == 0) {
			*line = cam->keys[i].line;
			return cam->keys[i].value;
		}
	return NULL;
}

void mcd_lockstep_check_config(const mcd_config *cfg)
{
	char where[PATH_MAX + 64];
	const char *mode = mcd_config_is_set(cfg, "daemon", "offline")
				   ? mcd_config_where(cfg, "daemon", "offline", where, sizeof(where))
				   : "--offline";
	for (int c = 0; c < cfg->ncams; c++) {
		const mcd_camera_config *cam = &cfg->cams[c];
		int line = cam->line, loop_line = cam->line;
		const char *rate = strcmp(cam->driver, "files") == 0 ? driver_key(cam, "rate", &line) : NULL;
		const char *loop = driver_key(cam, "loop", &loop_line);
		if (loop && (!strcasecmp(loop, "true") || !strcasecmp(loop, "yes") || !strcasecmp(loop, "on") ||
			     !strcmp(loop, "1")))
			mcd_warn("%s:%d: [camera %s] loop = %s: the camera never ends, so neither does %s", cfg->file,
				 loop_line, cam->name, loop, mode);
		if (live_driver(cam->driver))
			mcd_warn("camera %s: the %s driver is a live camera; with %s it loses the frames the tracker is "
				 "not ready for", cam->name, cam->driver, mode);
		else if (rate && strtod(rate, NULL) == 0)
			mcd_warn("%s:%d: [camera %s] rate = %s: the files driver then stamps each frame with the time it "
				 "is read, so with %s the cameras' frames do not group into frame sets; give the "
				 "recording's rate (offline, every frame is delivered at once all the same)",
				 cfg->file, line, cam->name, rate, mode);
	}
}


void mcd_lockstep_init(mcd_lockstep *l, mcd_tracking_thread *tracker, int ncams, uint64_t now)
{
	l->tracker = tracker;
	l->ncams = ncams < MC_MAX_CAMERAS ? ncams : MC_MAX_CAMERAS;
	for (int c = 0; c < MC_MAX_CAMERAS; c++)
		atomic_init(&l->delivered[c], 0);
	l->start_ns = l->prev_ns = now;
	l->next_ns = now + MCD_PROGRESS_INTERVAL_NS;
	l->prev_done = 0;
}

void mcd_lockstep_delivered(mcd_lockstep *l, int cam)
{
	if (cam >= 0 && cam < l->ncams)
		atomic_fetch_add(&l->delivered[cam], 1);
}

/* The frames of camera `cam` the tracking thread has taken: those in an
 * emitted frame set, and those it dropped as too late for theirs. */
static uint64_t taken(const mcd_track_stats *st, int cam)
{
	return st->total.sets - st->cams[cam].missing + st->cams[cam].late;
}

bool mcd_lockstep_may_deliver(mcd_lockstep *l, int cam)
{
	if (cam < 0 || cam >= l->ncams)
		return true;
	mcd_track_stats st; /* 2.5 KB, mostly each camera's last error text */
	mcd_tracking_thread_stats(l->tracker, &st, false);
	return taken(&st, cam) >= atomic_load(&l->delivered[cam]);
}

void mcd_lockstep_progress(mcd_lockstep *l, uint64_t now, bool final, uint64_t total)
{
	if (!final && now < l->next_ns)
		return;
	mcd_track_stats st;
	mcd_tracking_thread_stats(l->tracker, &st, false);
	const mcd_track_totals *t = &st.total;
	double since_start = (double)(now - l->start_ns) / 1e9, since_prev = (double)(now - l->prev_ns) / 1e9;
	if (final)
		mcd_info("offline: %llu frame sets, %llu tracked, in %.1f s (%.1f per second); skipped %llu behind, "
			 "%llu with a tracker error, %llu without every camera",
			 (unsigned long long)t->sets, (unsigned long long)t->tracked, since_start,
			 since_start > 0 ? (double)t->sets / since_start : 0.0, (unsigned long long)t->skipped,
			 (unsigned long long)t->track_errors, (unsigned long long)(t->sets - t->complete_sets));
	else if (total)
		/* The time left at the mean rate so far (the last second's
		 * varies with the tracker's iterations). */
		mcd_info("offline: %llu / %llu frame sets, %.0f %%, %llu tracked, %.1f per second, %.0f s in, ETA %.0f s",
			 (unsigned long long)t->sets, (unsigned long long)total,
			 100.0 * (double)(t->sets < total ? t->sets : total) / (double)total,
			 (unsigned long long)t->tracked,
			 since_prev > 0 ? (double)(t->sets - l->prev_done) / since_prev : 0.0, since_start,
			 t->sets > 0 && t->sets < total ? (double)(total - t->sets) * since_start / (double)t->sets : 0.0);
	else /* a camera's driver does not know its length (or it is live) */
		mcd_info("offline: %llu frame sets, %llu tracked, %.1f per second, %.0f s in",
			 (unsigned long long)t->sets, (unsigned long long)t->tracked,
			 since_prev > 0 ? (double)(t->sets - l->prev_done) / since_prev : 0.0, since_start);
	l->prev_done = t->sets;
	l->prev_ns = now;
	l->next_ns = now + MCD_PROGRESS_INTERVAL_NS;
}
