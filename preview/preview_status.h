/* preview_status: the JSON the page receives (event data), built with
 * jansson, and the last minute of tracking time and confidence for the
 * page's plot.  Every function returns a malloc'd one-line JSON text
 * (free it) or NULL when out of memory. */
#ifndef PREVIEW_STATUS_H
#define PREVIEW_STATUS_H

#include "mocap.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define HISTORY_SECONDS 60

/* One point a second: the daemon's mean tracking time then, and the mean
 * joint confidence of the skeletons received in that second. */
typedef struct {
	double t[HISTORY_SECONDS], track_ms[HISTORY_SECONDS], confidence[HISTORY_SECONDS];
	int n, head; /* points held; index of the oldest */
	double conf_sum;
	long conf_n;
} preview_history;

/* A skeleton arrived: its mean joint confidence counts for this second. */
void history_add_skeleton(preview_history *h, const mocap_skeleton_frame *f);
/* Closes the second: t seconds since start, the daemon's tracking time
 * (NAN when unknown).  The oldest point goes past HISTORY_SECONDS. */
void history_close_second(preview_history *h, double t, double track_ms);

/* What the page shows of the daemon.  st NULL: not connected (message
 * says why).  record_msg: the daemon's answer to "record status" ("" when
 * not privileged).  can_record: the record controls work (privileged). */
typedef struct {
	const mocap_daemon_status *st;
	const char *socket;
	const char *message;
	const char *record_msg;
	bool can_record;
	const preview_history *history;
} preview_status_in;

char *status_json(const preview_status_in *in);
/* The skeleton in the frame it came in: names, parents, positions, the
 * state and per-joint confidence. */
char *skeleton_json(const mocap_skeleton_def *def, const mocap_skeleton_frame *f);
/* One camera view: its index and name, size and the JPEG in base64. */
char *frame_json(int camera, const char *name, int width, int height, uint64_t seq, const uint8_t *jpeg,
		 size_t bytes);

/* Standard base64 (RFC 4648) of n bytes into a malloc'd string. */
char *base64_encode(const uint8_t *data, size_t n);

#endif
