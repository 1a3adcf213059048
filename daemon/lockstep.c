#include "lockstep.h"

#include "log.h"


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

void mcd_lockstep_progress(mcd_lockstep *l, uint64_t now, bool final)
{
	if (!final && now < l->next_ns)
		return;
	mcd_track_stats st;
	mcd_tracking_thread_stats(l->tracker, &st, false);
	const mcd_track_totals *t = &st.total;
	double since_start = (double)(now - l->start_ns) / 1e9, since_prev = (double)(now - l->prev_ns) / 1e9;
	/* The number of frame sets in the recording is not known to the
	 * daemon (the driver ABI has no frame count), so no total nor ETA. */
	if (final)
		mcd_info("offline: %llu frame sets, %llu tracked, in %.1f s (%.1f per second); skipped %llu behind, "
			 "%llu with a tracker error, %llu without every camera",
			 (unsigned long long)t->sets, (unsigned long long)t->tracked, since_start,
			 since_start > 0 ? (double)t->sets / since_start : 0.0, (unsigned long long)t->skipped,
			 (unsigned long long)t->track_errors, (unsigned long long)(t->sets - t->complete_sets));
	else
		mcd_info("offline: %llu frame sets, %llu tracked, %.1f per second, %.0f s in",
			 (unsigned long long)t->sets, (unsigned long long)t->tracked,
			 since_prev > 0 ? (double)(t->sets - l->prev_done) / since_prev : 0.0, since_start);
	l->prev_done = t->sets;
	l->prev_ns = now;
	l->next_ns = now + MCD_PROGRESS_INTERVAL_NS;
}
