/* vmc_config: mocap-vmc's settings, from the [vmc] section of its config
 * file (config/vmc.conf, docs/VMC.md "Configuration") and the command
 * line. */
#ifndef VMC_CONFIG_H
#define VMC_CONFIG_H

#include "base/mc_error.h"
#include "vmc_map.h"

#include <stdbool.h>

#define VMC_DEFAULT_PORT 39539
/* The floor under a head-mounted rig's own frame when no head pose gives
 * a world (about a standing adult's eye height). */
#define VMC_DEFAULT_RIG_FLOOR (-1.6)

typedef struct {
	char host[256];        /* the receiver (key `target` sets host and port) */
	int port;
	double rate;           /* bundles per second; 0: one per tracked frame */
	mocap_space space;     /* subscribed space: world (falls back to rig) or rig */
	int up;                /* a vmc_up, or -1: from the frame's space and the rig */
	bool floor_auto;
	double floor_height;   /* the floor along the up axis, metres */
	vmc_rest rest;
	float min_confidence;  /* below it a bone holds or eases to rest */
	vmc_low low;
	double ease_s;         /* time constant of easing to rest */
	char bones[4096];      /* bone file, "" = the default table */
} vmc_settings;

void vmc_settings_default(vmc_settings *s);
/* Reads the [vmc] section of path over s.  Errors name the file, line and
 * key. */
int vmc_settings_load(vmc_settings *s, const char *path, mc_err *err);
/* One setting from text (the config file and the command line share it):
 * 0, or -1 with the reason in err (without file or line). */
int vmc_settings_set(vmc_settings *s, const char *key, const char *value, mc_err *err);

/* The up axis and floor height in effect for a frame. */
vmc_up vmc_settings_up(const vmc_settings *s, const mocap_skeleton_frame *f, const mocap_skeleton_def *sk);
double vmc_settings_floor(const vmc_settings *s, vmc_up up);

#endif
