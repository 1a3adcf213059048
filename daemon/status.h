/* status: live figures from two pipeline snapshots: rates per camera and of
 * the tracker, as one text line (systemd STATUS=, the stats log line) and
 * as the socket server's status snapshot (mocapctl status). */
#ifndef MCD_STATUS_H
#define MCD_STATUS_H

#include "server.h"
#include "pipeline.h"

#include <stddef.h>
#include <stdint.h>

/* Frames lost for one camera: dropped by the capture checks, overwritten in
 * the ring, undecodable, or too late for their frame set. */
uint64_t mcd_cam_drops(const mcd_cam_status *c);

/* "tracking 29.9 fps, 31.2 ms (max 40.1), ok | left: streaming 30.0 fps, 0 drops | ..."
 * `prev` is the snapshot dt_s seconds earlier (rates are 0 when dt_s <= 0). */
void mcd_status_line(const mcd_pipeline_status *now, const mcd_pipeline_status *prev, double dt_s, char *buf,
		     size_t cap);

void mcd_status_to_server(const mcd_pipeline_status *now, const mcd_pipeline_status *prev, double dt_s,
			  uint64_t start_ns, const char *device, srv_status *out);

#endif
