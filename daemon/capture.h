/* capture: one configured camera, its driver instance and its capture thread.
 *
 * The capture thread opens the device through its driver plugin, starts it
 * and calls next_frame() into the next slot of the camera's frame ring
 * (frame_ring.h).  Good frames are committed and reported to the sink;
 * short, corrupt and malformed frames are dropped and counted.  When the
 * driver fails (open, start, an error mid-stream, the device gone, no frame
 * for stall_timeout) the thread closes the device and reopens it after an
 * exponential, capped backoff.  A config error from the driver, or a driver
 * key the driver never read, stops the camera for good (state FAILED); the
 * end of a finite stream stops it as ENDED.  Nothing here ever exits the
 * daemon.
 *
 * Driver keys: the driver reads its keys through mdrv_host.config_get; a
 * key of the camera's section it has not read by the time start() returned
 * is reported as unknown ("mocapd.conf:9: [camera left] fsp: unknown key
 * (the files driver does not read it)").  Besides the section's keys, the
 * host answers "epoch" (see mcd_camera_set_epoch), "driver" and
 * "rig_camera". */
#ifndef MCD_CAPTURE_H
#define MCD_CAPTURE_H

#include "config.h"
#include "frame_ring.h"
#include "base/mc_error.h"
#include "ring/mc_ring.h"
#include "mdrv.h"
#include "plugin.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef enum {
	MCD_CAM_OFF = 0,       /* thread not started */
	MCD_CAM_OPENING,       /* opening or starting the device */
	MCD_CAM_STREAMING,     /* delivering frames */
	MCD_CAM_STALLED,       /* open, but no frame for a while */
	MCD_CAM_RETRYING,      /* failed; waiting to reopen */
	MCD_CAM_FAILED,        /* given up: config error */
	MCD_CAM_ENDED,         /* finite stream ended */
} mcd_cam_state;

const char *mcd_cam_state_name(mcd_cam_state s);

typedef struct {
	uint64_t frames;         /* good frames committed to the ring */
	uint64_t short_frames;   /* dropped: fewer bytes than the format needs */
	uint64_t corrupt_frames; /* dropped: flagged corrupt or not decodable */
	uint64_t bad_frames;     /* dropped: malformed format fields */
	uint64_t timeouts;       /* next_frame timeouts */
	uint64_t errors;         /* driver errors (open, start, mid-stream) */
	uint64_t reopens;        /* times the device was reopened */
	uint64_t nospace;        /* frames that did not fit the slot */
	uint64_t lost;           /* never delivered: gaps in the driver's frame sequence */
	uint64_t last_frame_ns;  /* commit time of the newest frame, 0 = none */
	uint64_t expected_frames; /* what the driver said its recording has at the last opening; 0 = not known */
} mcd_cam_counters;

/* Where a camera reports; called on its capture thread. */
typedef struct {
	void *ctx;
	/* A frame was committed to the camera's ring; `generation` names the
	 * ring (it changes when the ring is replaced). */
	void (*on_frame)(void *ctx, int cam, uint64_t generation, const mc_ring_meta *meta);
	/* The state changed, or the ring was replaced (new fd). */
	void (*on_change)(void *ctx, int cam);
	/* NULL for live cameras.  Offline mode (lockstep.h): whether the
	 * camera may ask its driver for the next frame; until it may, the
	 * capture thread waits, polling every millisecond, and the wait is
	 * not a stall. */
	bool (*may_deliver)(void *ctx, int cam);
} mcd_camera_sink;

typedef struct mcd_camera mcd_camera;

/* `cfg` is copied; `plugin` must outlive the camera; `config_file` names the
 * file in messages. */
mcd_camera *mcd_camera_create(int index, const mcd_camera_config *cfg, const char *config_file,
			      const mcd_plugin *plugin, const mcd_camera_sink *sink, mc_err *err);
int mcd_camera_start(mcd_camera *c, mc_err *err);
/* Asks the thread to stop (it notices within ~200 ms unless a driver call blocks). */
void mcd_camera_request_stop(mcd_camera *c);
/* Waits up to timeout_ms for the thread; 0 when it ended, -1 if it is stuck
 * in the driver. */
int mcd_camera_join(mcd_camera *c, int timeout_ms);
/* Frees everything; the thread must have been joined (else it leaks it). */
void mcd_camera_destroy(mcd_camera *c);

/* mocapd --check: the driver checks the camera's keys and values without
 * opening a device (mdrv_driver.check), and every key must be one the
 * driver read.  Errors name the config file, the section and the key. */
int mcd_camera_check(mcd_camera *c, mc_err *err);

/* A CLOCK_MONOTONIC time origin shared by all cameras, offered to the
 * driver as the key "epoch" on the first opening when the config gives
 * none (call before start). */
void mcd_camera_set_epoch(mcd_camera *c, uint64_t epoch_ns);

/* Reload: reopen backoff and stall limit. */
void mcd_camera_set_limits(mcd_camera *c, double reopen_initial_ms, double reopen_max_ms, double stall_timeout_ms);

const char *mcd_camera_name(const mcd_camera *c);
const char *mcd_camera_driver(const mcd_camera *c);
mcd_cam_state mcd_camera_state(const mcd_camera *c);
/* True once the first attempt to open the camera has finished, either way. */
bool mcd_camera_attempted(const mcd_camera *c);
/* Counts the capture loop's iterations: it stops growing when the thread
 * is stuck (for the watchdog). */
uint64_t mcd_camera_heartbeat(const mcd_camera *c);
void mcd_camera_counters(const mcd_camera *c, mcd_cam_counters *out);
/* The current format (zeros before the first opening). */
mdrv_format mcd_camera_format(const mcd_camera *c);
void mcd_camera_last_error(const mcd_camera *c, char *buf, size_t cap);

/* The camera's frame ring: the tracking thread reads its frames there,
 * clients get its memfd. */
mcd_frame_ring *mcd_camera_ring(mcd_camera *c);

#endif
