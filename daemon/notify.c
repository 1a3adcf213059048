#include "notify.h"

#include "log.h"

#include <stdio.h>
#include <systemd/sd-daemon.h>
#include "base/mc_time.h"

static void notify_send(const char *msg)
{
	int rc = sd_notify(0, msg);
	if (rc < 0)
		mcd_debug("sd_notify: %s: error %d", msg, rc);
}

void mcd_notify_ready(const char *status)
{
	char msg[1200];
	snprintf(msg, sizeof(msg), "READY=1\nSTATUS=%.1100s", status ? status : "running");
	notify_send(msg);
}

void mcd_notify_status(const char *status)
{
	char msg[1200];
	snprintf(msg, sizeof(msg), "STATUS=%.1100s", status);
	notify_send(msg);
}

void mcd_notify_reloading(void)
{
	/* MONOTONIC_USEC lets systemd >= 253 (Type=notify-reload) match the
	 * READY=1 that ends the reload; older versions ignore it. */
	char msg[128];
	snprintf(msg, sizeof(msg), "RELOADING=1\nMONOTONIC_USEC=%llu", (unsigned long long)(mc_now_ns() / 1000));
	notify_send(msg);
}

void mcd_notify_stopping(void)
{
	notify_send("STOPPING=1\nSTATUS=stopping");
}

void mcd_notify_watchdog(void)
{
	notify_send("WATCHDOG=1");
}

uint64_t mcd_watchdog_usec(void)
{
	uint64_t usec = 0;
	return sd_watchdog_enabled(0, &usec) > 0 ? usec : 0;
}
