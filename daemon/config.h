/* config: mocapd's INI configuration (inih), checked key by key.
 *
 * Sections: [daemon], one [camera NAME] per camera, [tracker], [socket],
 * [detector], [network], [record], [source], [output].
 * Every error names the file, the line and the key, e.g.
 *   "mocapd.conf:12: [tracker] iterations: expected a positive integer, got 'abc'"
 * Unknown keys and sections are errors.  In a camera section the keys the
 * daemon does not know itself are driver keys: they are kept, in order, and
 * handed to the driver through mdrv_host.config_get; the capture thread then
 * rejects those the driver never asked for (see mcd_camera_config.keys).
 * Relative paths are resolved against the directory of the config file:
 * those of the daemon's own keys and driver keys named "path" or "*_path".
 *
 * The daemon's own keys are one table (mcd_config_keys): each key's
 * section, type, field, range, default and whether a reload applies it.
 * The table drives parsing and validation (config.c), the defaults, and
 * the reload (mcd_config_take_reloadable); tests/test_daemon_config_doc.c
 * checks docs/CONFIG.md against it. */
#ifndef MCD_CONFIG_H
#define MCD_CONFIG_H

#include "base/mc_error.h"
#include "base/mc_limits.h"
#include "track/mc_tracker.h"

#include <limits.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

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

typedef enum { MCD_RIG_JSON = 0, MCD_RIG_EGO_CALIB = 1, MCD_RIG_CAMERAS_JSON = 2 } mcd_rig_format;

/* The tracker section.  The tracker's own settings are read straight into
 * `settings`, which starts from mc_tracker_settings_default: a key left
 * out keeps the tracker's default. */
typedef struct {
	bool enabled;
	int line; /* of the section header, 0 if absent */
	char rig[PATH_MAX];
	mcd_rig_format rig_format;
	bool rig_ocam; /* ego-calib: use the fitted OCam polynomial */
	char model[PATH_MAX];
	char init_joints[PATH_MAX]; /* gt.json whose frame 0 gives the joints; "" = from detections */
	char actor[PATH_MAX];       /* actor file (a model file with the actor's size and colours); "" = none */
	char actor_dir[PATH_MAX];   /* where `mocapctl actor save NAME` writes NAME.json */
	char pose_prior[PATH_MAX];  /* the learned pose prior (docs/TRACKER.md); "" = none */
	bool calibrate_colors;
	mc_tracker_settings settings;
} mcd_tracker_config;

typedef struct {
	bool enabled;             /* false: no client socket at all */
	char path[PATH_MAX];
	char group[MCD_NAME_MAX]; /* "" = the daemon's group */
	unsigned mode;            /* permission bits of the socket file */
	int max_clients;
} mcd_socket_config;

/* The [network] section: clients on other machines (TCP, off by default). */
typedef struct {
	char listen[256];          /* "HOST:PORT"; "" = no TCP listener */
	char token_file[PATH_MAX]; /* the access token's file; required with listen */
	bool privileged;           /* TCP clients may control and send inputs */
} mcd_network_config;

/* The [record] section: where takes go and what they keep
 * (recorder.h, docs/RECORDING.md). */
typedef struct {
	char directory[PATH_MAX]; /* takes are DIRECTORY/NAME */
	bool frames;              /* keep the camera frames (else skeletons only) */
	double max_seconds;       /* stop a take after this long; 0: no limit */
	double max_mb;            /* stop a take at this size (10^6 bytes); 0: no limit */
	double sync_ms;           /* fdatasync period: what a power loss may cost; 0: every record */
} mcd_record_config;

/* The [detector] section: the in-process 2D joint detector
 * (detector_thread.h).  An empty model means no detector. */
typedef struct {
	char model[PATH_MAX];  /* ONNX file; "" = no detector */
	double rate;           /* detections per second per camera; 0 = every frame */
	int threads;           /* OpenCV threads (process-wide) */
	double min_confidence; /* keypoints below it are dropped; < 0: the model's threshold */
	int nice;              /* the detector threads' nice value above the daemon's */
	int hint;              /* mcd_detector_hint: MoveNet looks where the tracked pose is */
	bool flip;             /* heatmap models: the flip test (mirrored view averaged in) */
} mcd_detector_config;

/* [detector] hint: where a MoveNet model looks first (docs/DETECT_RUNTIME.md). */
typedef enum { MCD_HINT_NONE = 0, MCD_HINT_POSE = 1 } mcd_detector_hint;

/* The [output] section: what is done to the skeletons before clients get
 * them (publish.h).  The One-Euro filter's parameters
 * (core/base/mc_one_euro.h); they are kept when the filter is off. */
typedef enum { MCD_FILTER_NONE = 0, MCD_FILTER_ONE_EURO = 1 } mcd_filter_kind;
typedef struct {
	int filter;              /* mcd_filter_kind */
	double min_cutoff_hz;    /* the cutoff at rest */
	double beta;             /* cutoff added per m/s of a joint's speed */
	double d_cutoff_hz;      /* the cutoff of the speed estimate */
	double max_gap_ms;       /* a longer gap between skeletons restarts the filter */
} mcd_output_config;

/* The [source] section: a synthetic source instead of cameras and tracker
 * (graph_source.h, docs/MOTION_GRAPH.md): graph walks as skeletons. */
typedef struct {
	char graph[PATH_MAX]; /* a mocap-graph file; "" = cameras and tracker */
	int kind;             /* MC_EDGE_ESSENTIAL or MC_EDGE_MOTION */
	double rate;          /* skeletons per second */
	int seed;
} mcd_source_config;

typedef struct {
	char file[PATH_MAX]; /* as given, for messages */
	char dir[PATH_MAX];  /* its directory, for relative paths */

	/* [daemon] */
	char plugin_dir[PATH_MAX];
	int log_level;
	bool print;
	double group_tolerance_ms;
	double group_deadline_ms;
	double max_frame_age_ms; /* 0: no budget */
	double reopen_initial_ms;
	double reopen_max_ms;
	double stall_timeout_ms;
	double status_interval_s;
	double stats_log_interval_s;
	/* Track every frame set of finite recordings, capture waiting for the
	 * tracker (lockstep.h); mocapd --offline sets it. */
	bool offline;

	int ncams;
	mcd_camera_config cams[MC_MAX_CAMERAS];
	mcd_tracker_config tracker;
	mcd_socket_config socket;
	mcd_network_config network;
	mcd_detector_config detector;
	mcd_record_config record;
	mcd_source_config source;
	mcd_output_config output;

	/* Where each key was given, for messages about values checked later
	 * (a rig file that fails to load, a socket group that does not exist). */
	int nwhere;
	struct {
		char section[MCD_NAME_MAX + 8];
		char key[MCD_NAME_MAX];
		int line;
	} where[80 + MC_MAX_CAMERAS * (8 + MCD_MAX_DRIVER_KEYS)]; /* every key a valid file can hold */
} mcd_config;

/* Fills the defaults of the key table (compiled-in plugin directory,
 * socket /run/mocapd/mocapd.sock, the tracker's own settings). */
void mcd_config_defaults(mcd_config *cfg);
/* Loads and checks a file.  cfg is heap-sized; allocate it with calloc. */
int mcd_config_load(const char *path, mcd_config *cfg, mc_err *err);
/* The same from a text; `origin` names it in messages, relative paths are
 * resolved against base_dir. */
int mcd_config_parse(const char *text, const char *origin, const char *base_dir, mcd_config *cfg, mc_err *err);

/* Every error of a file, not only the first (mocapd --check): lines
 * "file:line: message\n" appended to buf (NUL-terminated; lines that do
 * not fit are counted, not written).  err gets the first, as above. */
typedef struct {
	char *buf;
	size_t cap, len;
	int n;       /* errors found */
	int untold;  /* of them, those that did not fit in buf */
} mcd_config_errors;
int mcd_config_load_all(const char *path, mcd_config *cfg, mcd_config_errors *all, mc_err *err);
int mcd_config_parse_all(const char *text, const char *origin, const char *base_dir, mcd_config *cfg,
			 mcd_config_errors *all, mc_err *err);


/* "mocapd.conf:12: [tracker] rig" for a key that was given, or
 * "mocapd.conf: [tracker] rig" for one left at its default.  `section` is
 * the name between the brackets, e.g. "camera left". Returns buf. */
const char *mcd_config_where(const mcd_config *cfg, const char *section, const char *key, char *buf, size_t cap);
/* Whether the file gave [section] key (rather than its default). */
bool mcd_config_is_set(const mcd_config *cfg, const char *section, const char *key);

/* The value of a driver key of a camera, or NULL. */
const mcd_kv *mcd_camera_config_find(const mcd_camera_config *cam, const char *key);

/* ---- the key table ------------------------------------------------------ */

typedef enum {
	MCD_SEC_DAEMON,
	MCD_SEC_CAMERA,
	MCD_SEC_TRACKER,
	MCD_SEC_SOCKET,
	MCD_SEC_DETECTOR,
	MCD_SEC_NETWORK,
	MCD_SEC_RECORD,
	MCD_SEC_SOURCE,
	MCD_SEC_OUTPUT,
} mcd_section;
#define MCD_NSECTIONS 9

typedef enum {
	MCD_KEY_BOOL,     /* true/false, yes/no, on/off, 1/0 */
	MCD_KEY_INT,      /* int in [lo, hi] */
	MCD_KEY_U64,      /* uint64_t, any non-negative integer */
	MCD_KEY_REAL,     /* double in [lo, hi] */
	MCD_KEY_POSITIVE, /* double in (0, hi] */
	MCD_KEY_STRING,   /* non-empty text */
	MCD_KEY_NAME,     /* letters, digits, '_' and '-' */
	MCD_KEY_PATH,     /* relative to the config file's directory */
	MCD_KEY_OPT_PATH, /* the same, or empty for none */
	MCD_KEY_ENUM,     /* one of `choices`, stored as an int */
	MCD_KEY_CL_INDEX, /* "auto" (-1) or an index 0..63 */
	MCD_KEY_MODE,     /* octal permission bits, with the leading 0 */
	MCD_KEY_REAL_AUTO, /* "auto" (stored as -1) or a double in [lo, hi] */
	MCD_KEY_HOST_PORT, /* "HOST:PORT" or "[IPV6]:PORT", port 0..65535 */
} mcd_key_type;

typedef struct {
	const char *name;
	int value;
	bool alias; /* accepted, but not listed in messages nor printed */
} mcd_key_choice;

typedef struct {
	mcd_section section;
	const char *key;
	mcd_key_type type;
	/* The field: in mcd_config, or in mcd_camera_config for camera keys. */
	size_t offset, size;
	double lo, hi;                 /* INT, REAL, POSITIVE: the range; PATH: hi > 0 caps
					* the length at hi - 1 bytes (sun_path) */
	const mcd_key_choice *choices; /* ENUM, ended by a NULL name */
	/* The default as it would be written in the file; NULL: none (the key
	 * is required or optional), or, for the keys in mcd_tracker_config's
	 * settings, the tracker's own default. */
	const char *def;
	bool reload; /* a reload applies a new value; else it takes a restart */
} mcd_config_key;

/* The table, in documentation order; *n gets its length. */
const mcd_config_key *mcd_config_keys(size_t *n);
/* The entry for `key` in a section, or NULL. */
const mcd_config_key *mcd_config_key_find(mcd_section section, const char *key);
/* The known key of `section`, or section name, that an unknown one is
 * most likely a typo of; NULL if none is close (config_suggest.c). */
const char *mcd_config_suggest_key(mcd_section section, const char *key);
const char *mcd_config_suggest_section(const char *name);
/* The same among n names stored every `stride` bytes from `names`. */
const char *mcd_suggest_name(const char *typed, const char *names, size_t stride, int n);
/* "daemon", "camera", "tracker", "socket", "detector", "network", "record",
 * "source" or "output". */
const char *mcd_section_name(mcd_section section);
/* Parses `value` into the key's field of `base` (an mcd_config, or an
 * mcd_camera_config for camera keys).  On error returns -1 with why (no
 * file, line or key: the caller adds them). */
int mcd_config_key_parse(const mcd_config_key *k, const char *value, void *base, const char *base_dir, char *why,
			 size_t whylen);
/* The key's value in `base` as it would be written in the file ("" for an
 * empty string). Returns buf. */
const char *mcd_config_key_format(const mcd_config_key *k, const void *base, char *buf, size_t cap);
/* Sets the table's defaults of camera keys in a new camera section. */
void mcd_camera_config_defaults(mcd_camera_config *cam);

/* Reload: copies from `neu` into `cur` the value of every key the table
 * marks reloadable, and logs each other key (and the cameras) that
 * changed, as taking a restart.  Returns how many changes were refused.
 * `changes` (may be NULL) gets "nothing changed", or "applied: [tracker]
 * iterations, ..." and/or MCD_RELOAD_NEEDS_RESTART "[daemon] plugin_dir,
 * ...", for the client that asked (mocapctl reload). */
#define MCD_RELOAD_NEEDS_RESTART "needs a restart: "
int mcd_config_take_reloadable(mcd_config *cur, const mcd_config *neu, char *changes, size_t cap);

#endif
