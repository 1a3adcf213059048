/* notify: the daemon's side of the systemd service protocol (sd_notify).
 *
 * Without $NOTIFY_SOCKET (not started by systemd) every call does nothing.
 * The watchdog is fed by the main loop only when the pipeline's threads
 * have all made progress (pipeline.h: mcd_pipeline_progress), never from a
 * timer of its own: a stuck pipeline stops the pings and systemd restarts
 * the service. */
#ifndef MCD_NOTIFY_H
#define MCD_NOTIFY_H

#include <stdint.h>

void mcd_notify_ready(const char *status);
void mcd_notify_status(const char *status);
void mcd_notify_reloading(void);
void mcd_notify_stopping(void);
void mcd_notify_watchdog(void);
/* The watchdog period systemd asked for, in microseconds; 0 if none. */
uint64_t mcd_watchdog_usec(void);

#endif
