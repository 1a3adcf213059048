/* config: mocapd's INI configuration (inih), checked key by key.
 *
 * Sections: [daemon], one [camera NAME] per camera, [tracker], [socket].
 * Every error names the file, the line and the key, e.g.
 *   "mocapd.conf:12: [tracker] iterations: expected a positive integer, got 'abc'"
 * Unknown keys and sections are errors.  In a camera section the keys the
 * daemon does not know itself are driver keys: they are kept, in order, and
 * handed to the driver through mdrv_host.config_get; the camera code then
 * rejects those the driver never asked for (see mcd_camera_config.keys).
 * Relative paths are resolved against the directory of the config file:
 * those of the daemon's own keys and driver keys named "path" or "*_path".
 * Every key is documented in docs/CONFIG.md. */
#ifndef MCD_CONFIG_H
#define MCD_CONFIG_H

#include "base/mc_error.h"

#include <limits.h>
#include <stdbool.h>
#include <stdint.h>

#define MCD_MAX_CAMERAS 8
#define MCD_MAX_DRIVER_KEYS 32
#define MCD_NAME_MAX 64
#define MCD_VALUE_MAX 256

typedef struct {
	char key[MCD_NAME_MAX];
	char value[MCD_VALUE_MAX];
	int line;
} mcd_kv;

typedef struct {
	char name[MCD_NAME_MAX]; /* from "[camera NAME]" */
	int line;                /* of the section header */
	char driver[MCD_NAME_MAX];
	int driver_line;
	char rig_camera[MCD_NAME_MAX]; /* rig camera this one is; "" = not tracked */
	int rig_camera_line;
	int ring_slots;           /* frames kept in the camera's ring */
	int nkeys;                /* driver keys, passed through */
	mcd_kv keys[MCD_MAX_DRIVER_KEYS];
} mcd_camera_config;

typedef enum { MCD_RIG_JSON = 0, MCD_RIG_EGO_CALIB = 1 } mcd_rig_format;

/* The tracker section.  Numeric settings at -1 (or NaN for reals) keep the
 * tracker's own default (mc_tracker_settings_default). */
typedef struct {
	bool enabled;
	int line; /* of the section header, 0 if absent */
	char rig[PATH_MAX];
	mcd_rig_format rig_format;
	bool rig_ocam; /* ego-calib: use the fitted OCam polynomial */
	char model[PATH_MAX];
	char init_joints[PATH_MAX]; /* gt.json whose frame 0 gives the joints; "" = rest pose */
	bool calibrate_colors;
	int backend; /* -1 default, else mc_backend */
	int width, height, iterations;
	double pixel_fraction, dropout, step, momentum;
	double lambda_detection, lambda_smooth; /* NAN: default */
	int cl_platform, cl_device; /* -2 default, -1 auto, >= 0 index */
	long long seed;             /* -1 default */
} mcd_tracker_config;

typedef struct {
	bool enabled;             /* false: no client socket at all */
	char path[PATH_MAX];
	char group[MCD_NAME_MAX]; /* "" = the daemon's group */
	unsigned mode;            /* permission bits of the socket file */
	int max_clients;
} mcd_socket_config;

typedef struct {
	char file[PATH_MAX]; /* as given, for messages */
	char dir[PATH_MAX];  /* its directory, for relative paths */

	/* [daemon] */
	char plugin_dir[PATH_MAX];
	int log_level;
	bool print;
	double group_tolerance_ms;
	double group_deadline_ms;
	double reopen_initial_ms;
	double reopen_max_ms;
	double stall_timeout_ms;
	double status_interval_s;
	double stats_log_interval_s;

	int ncams;
	mcd_camera_config cams[MCD_MAX_CAMERAS];
	mcd_tracker_config tracker;
	mcd_socket_config socket;

	/* Where each key was given, for messages about values checked later
	 * (a rig file that fails to load, a socket group that does not exist). */
	int nwhere;
	struct {
		char section[MCD_NAME_MAX + 8];
		char key[MCD_NAME_MAX];
		int line;
	} where[160];
} mcd_config;

/* Fills defaults (compiled-in plugin directory, socket /run/mocapd/mocapd.sock). */
void mcd_config_defaults(mcd_config *cfg);
/* Loads and checks a file.  cfg is heap-sized; allocate it with calloc. */
int mcd_config_load(const char *path, mcd_config *cfg, mc_err *err);
/* The same from a text; `origin` names it in messages, relative paths are
 * resolved against base_dir. */
int mcd_config_parse(const char *text, const char *origin, const char *base_dir, mcd_config *cfg, mc_err *err);

/* "mocapd.conf:12: [tracker] rig" for a key that was given, or
 * "mocapd.conf: [tracker] rig" for one left at its default.  `section` is
 * the name between the brackets, e.g. "camera left". Returns buf. */
const char *mcd_config_where(const mcd_config *cfg, const char *section, const char *key, char *buf, size_t cap);

/* The value of a driver key of a camera, or NULL. */
const mcd_kv *mcd_camera_config_find(const mcd_camera_config *cam, const char *key);

#endif
