/* probe: `mocapd --probe`, for setting up real cameras.  Every driver
 * plugin in the plugin directory lists the devices it finds
 * (mdrv_driver.probe) and, where it can, their modes (mdrv_driver.modes,
 * driver ABI 3); for each device a [camera] section is printed that can be
 * pasted into mocapd.conf. */
#ifndef MCD_PROBE_H
#define MCD_PROBE_H

#include "base/mc_error.h"

#include <stdio.h>

/* Probes every mocap-driver-*.so in plugin_dir (each under the trust rules
 * of plugin.h) and writes the report to out.  Returns the number of
 * devices found (>= 0), or -1 with err when the directory cannot be read.
 * A plugin that does not load or probe is reported in out and skipped. */
int mcd_probe_all(const char *plugin_dir, FILE *out, mc_err *err);

#endif
