/* lockstep: the offline mode ([daemon] offline, mocapd --offline).
 *
 * Live, the tracking thread tracks the newest frame set that is due and
 * counts older ones as skipped, and the capture threads never wait: a live
 * pose is worth more than a complete but late one.  Tracking recorded
 * footage wants the opposite: every frame set, as fast as the machine
 * goes.  In offline mode each capture thread asks for its camera's next
 * frame only once the tracking thread has taken (grouped and popped) every
 * frame the camera delivered before, so that at most one frame set waits
 * while another is tracked and none is ever skipped for being behind.
 *
 * The tracking thread has no hook for "a frame set was taken" (and belongs
 * to another module), so a waiting camera looks at its counters: a
 * camera's frames are taken when they went into an emitted frame set
 * (sets - missing) or were dropped as late.  The look is a lock and a
 * copy, every millisecond while waiting; the tracking of one frame set
 * takes tens of milliseconds or more.
 *
 * It also logs the progress line (frame sets tracked, per second), at most
 * once a second; with the recording's length (the drivers' frame counts)
 * also the share done and the time left. */
#ifndef MCD_LOCKSTEP_H
#define MCD_LOCKSTEP_H

#include "base/mc_limits.h"
#include "config.h"
#include "tracking_thread.h"

#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

/* The time origin offered to every camera in offline mode: one second
 * after boot, so that drivers that deliver a recorded frame no earlier
 * than its time (files with rate > 0, take, gstreamer with pace =
 * realtime) find every frame already due and deliver it at once, still
 * stamped with its own time in the recording (frame k: origin + k / fps).
 * A recording longer than the machine's uptime is paced from there on. */
#define MCD_OFFLINE_EPOCH_NS 1000000000ull

#define MCD_PROGRESS_INTERVAL_NS 1000000000ull /* at most one progress line a second */

typedef struct {
	mcd_tracking_thread *tracker;
	int ncams;
	atomic_uint_fast64_t delivered[MC_MAX_CAMERAS]; /* frames each camera handed on */
	/* The progress line (main thread only). */
	uint64_t start_ns, next_ns, prev_ns, prev_done;
} mcd_lockstep;

/* Warns of cameras that offline mode does not suit: live ones (held back,
 * they lose frames), a files camera with rate = 0 (stamped when read, its
 * frames do not group with the other cameras') and a looping one (it
 * never ends). */
void mcd_lockstep_check_config(const mcd_config *cfg);

void mcd_lockstep_init(mcd_lockstep *l, mcd_tracking_thread *tracker, int ncams, uint64_t now);
/* Camera `cam` handed a frame to the tracking thread (its capture thread). */
void mcd_lockstep_delivered(mcd_lockstep *l, int cam);
/* Whether camera `cam` may deliver its next frame: the tracking thread has
 * taken every frame it delivered so far (its capture thread). */
bool mcd_lockstep_may_deliver(mcd_lockstep *l, int cam);
/* Logs the progress line when a second has passed since the last one, or
 * with `final` the totals; `total`: the frame sets expected (0: not
 * known).  Main thread. */
void mcd_lockstep_progress(mcd_lockstep *l, uint64_t now, bool final, uint64_t total);

#endif
