/* mdrv.h: the one ABI between mocapd and its camera driver plugins.
 *
 * A plugin is a shared object `mocap-driver-NAME.so` that exports
 *
 *     const mdrv_driver *mdrv_entry(void);
 *
 * The host checks `abi_version` against MDRV_ABI_VERSION and refuses
 * a plugin built for a version it does not speak (below
 * MDRV_ABI_MIN_VERSION or above MDRV_ABI_VERSION).  The host owns the threads: for each opened camera it calls
 * next_frame() in a loop on a capture thread of its own, giving the driver a
 * slot (memory in the camera's frame ring) to fill.  Drivers never allocate
 * frame memory the host must free, never call exit(), and report every
 * failure as a negative mdrv_status with a message in `err`.
 *
 * Any change to a struct or function here bumps MDRV_ABI_VERSION.  A
 * version that only appends an optional member to mdrv_driver keeps
 * MDRV_ABI_MIN_VERSION: the host reads the new member only from plugins
 * whose abi_version has it. */
#ifndef MDRV_H
#define MDRV_H

#include <stddef.h>
#include <stdint.h>

#include "image/mc_pixfmt.h"

#ifdef __cplusplus
extern "C" {
#endif

/* 2: mdrv_driver.check (keys checked without a device, for mocapd --check)
 * 3: mdrv_mode and mdrv_driver.modes (a found device's modes, for
 *    mocapd --probe), appended at the end of mdrv_driver
 * 4: mdrv_driver.frame_count (how many frames a recording delivers, for
 *    mocapd --offline's progress), appended; ABI 3 plugins still load */
#define MDRV_ABI_VERSION 4u
#define MDRV_ABI_MIN_VERSION 3u
#define MDRV_ENTRY_SYMBOL "mdrv_entry"

typedef enum {
	MDRV_OK = 0,
	MDRV_ERR_IO = -1,      /* transient or unknown I/O error; the host may retry */
	MDRV_ERR_NODEV = -2,   /* the device is gone (unplugged); reopen later */
	MDRV_ERR_TIMEOUT = -3, /* no frame within timeout_ms; not an error by itself */
	MDRV_ERR_CONFIG = -4,  /* bad or missing config key; will not succeed on retry */
	MDRV_ERR_FORMAT = -5,  /* unsupported format or size */
	MDRV_ERR_NOSPACE = -6, /* the frame does not fit the slot's capacity */
	MDRV_ERR_END = -7,     /* end of a finite stream (e.g. files without loop) */
} mdrv_status;

typedef struct {
	uint32_t pixfmt;  /* mc_pixfmt */
	uint32_t width, height;
	uint32_t stride;  /* bytes per row; 0 for compressed formats */
	double fps;       /* nominal; 0 if unknown or free-running */
	size_t max_bytes; /* the largest frame the driver can deliver */
} mdrv_format;

enum {
	MDRV_FRAME_CORRUPT = 1u << 0, /* the driver knows the data is damaged */
	MDRV_FRAME_SHORT = 1u << 1,   /* fewer bytes than the format needs */
};

/* A slot the host gives to next_frame(). The driver writes into data (at most
 * capacity bytes) and fills the other fields. */
typedef struct {
	uint8_t *data;
	size_t capacity;
	size_t bytesused;
	uint64_t timestamp_ns; /* CLOCK_MONOTONIC, as close to exposure as possible */
	uint64_t sequence;     /* the driver's own frame counter */
	uint32_t flags;        /* MDRV_FRAME_* */
	mdrv_format format;   /* of this frame */
} mdrv_frame;

enum { MDRV_LOG_ERROR = 0, MDRV_LOG_WARN = 1, MDRV_LOG_INFO = 2, MDRV_LOG_DEBUG = 3 };

/* What the host offers a driver. */
typedef struct {
	void *ctx;
	/* The value of `key` in this camera's config section, or NULL.  The
	 * host reports keys no driver call asked for as config errors; asking
	 * for "prefix.*" (returns NULL) claims every key starting with
	 * "prefix." as read, for keys the driver uses later. */
	const char *(*config_get)(void *ctx, const char *key);
	void (*log)(void *ctx, int level, const char *msg);
	/* A driver whose open() fails says why with this before it returns
	 * NULL (drv_open_failed): MDRV_ERR_CONFIG (a bad key value, a missing
	 * or unreadable input, an undecodable first frame) is permanent and
	 * the host gives the camera up (state failed); any other status, or
	 * none, is retried with backoff.  May be NULL (an older host). */
	void (*open_status)(void *ctx, int status);
} mdrv_host;

typedef struct {
	char id[128];       /* what the config's `device` key takes to select it */
	char name[128];     /* human-readable model name */
	char bus_info[128]; /* stable physical location, e.g. usb-0000:00:14.0-2 */
	char serial[64];    /* empty if unknown */
} mdrv_device_info;

/* One mode a device offers: a pixel format at one size, and the rates it
 * takes there.  What mocapd --probe prints, and what the config keys
 * pixel_format, width, height and fps select. */
#define MDRV_MODE_RATES 16
typedef struct {
	char format_key[24];     /* the config key that selects the format; "" means "pixel_format" */
	char pixel_format[24];   /* the value that key takes, e.g. "YUYV", "Mono8" (or "depth" for openni2's "stream") */
	uint32_t pixfmt;         /* mc_pixfmt of the frames delivered in this mode */
	uint32_t width, height;  /* pixels; for a sensor with a free region, its largest */
	uint32_t nfps;           /* how many discrete rates fps[] holds, highest first */
	double fps[MDRV_MODE_RATES];
	double fps_min, fps_max; /* a continuous range instead (nfps 0); 0, 0 when unknown */
} mdrv_mode;

typedef struct mdrv_driver {
	uint32_t abi_version; /* MDRV_ABI_VERSION */
	const char *name;     /* "v4l2", "files", ... */
	const char *description;

	/* Lists up to `max` devices; returns how many were found (>= 0) or a
	 * negative mdrv_status with a message. */
	int (*probe)(const mdrv_host *host, mdrv_device_info *out, int max, char *err, size_t errlen);
	/* Opens the device selected by the config section. NULL on error. */
	void *(*open)(const mdrv_host *host, char *err, size_t errlen);
	/* The format frames will have after start(). */
	int (*get_format)(void *dev, mdrv_format *fmt, char *err, size_t errlen);
	int (*start)(void *dev, char *err, size_t errlen);
	/* Waits up to timeout_ms for the next frame and copies it into slot.
	 * Returns MDRV_OK, MDRV_ERR_TIMEOUT, MDRV_ERR_END or an error. */
	int (*next_frame)(void *dev, mdrv_frame *slot, int timeout_ms, char *err, size_t errlen);
	void (*stop)(void *dev);
	void (*close)(void *dev);
	/* Checks the config section's keys and values as open() would, without
	 * opening a device (input files may be read to check them), for
	 * mocapd --check: MDRV_OK, or MDRV_ERR_CONFIG with a message naming
	 * the key and the value.  Keys read here count as known to the host,
	 * which reports the others.  May be NULL: the keys are then checked at
	 * open() only. */
	int (*check)(const mdrv_host *host, char *err, size_t errlen);
	/* ABI 3.  Lists up to `max` modes of the device `id` (an id that
	 * probe() returned) in the formats this driver delivers; returns how
	 * many (>= 0) or a negative mdrv_status with a message.  Opens the
	 * device briefly if it must, never starts streaming, and leaves its
	 * settings as they were.  The host calls it with a host whose
	 * config_get returns NULL for every key.  May be NULL (mocapd --probe
	 * then lists the device without modes).  Plugins that define their
	 * descriptor with MDRV_DEFINE_DRIVER get NULL here; those that
	 * implement it use MDRV_DEFINE_DRIVER_MODES. */
	int (*modes)(const mdrv_host *host, const char *id, mdrv_mode *out, int max, char *err, size_t errlen);
	/* ABI 4.  How many frames the opened device will deliver from
	 * start() to its end (MDRV_ERR_END): a recording's frame count, from
	 * where the config starts it.  MDRV_OK with *frames, or a negative
	 * mdrv_status when it is not known (a live camera, a recording that
	 * loops, a file without a duration).  Called after open(), on the
	 * capture thread.  May be NULL; the host reads it only from plugins
	 * whose abi_version is 4 or more (MDRV_DEFINE_DRIVER_COUNT sets it). */
	int (*frame_count)(void *dev, uint64_t *frames);
} mdrv_driver;

typedef const mdrv_driver *(*mdrv_entry_fn)(void);

#ifdef __cplusplus
#define MDRV_ENTRY_LINKAGE extern "C"
#else
#define MDRV_ENTRY_LINKAGE
#endif

/* Defines a plugin's descriptor and its entry point in one place.  The
 * plugin names its callbacks after itself: PREFIX_probe, PREFIX_open,
 * PREFIX_get_format, PREFIX_start, PREFIX_next_frame, PREFIX_stop and
 * PREFIX_close and PREFIX_check; MODES is PREFIX_modes or NULL, COUNT
 * PREFIX_frame_count or NULL.  Positional initialisers, so that C++
 * plugins use it too. */
#define MDRV_DEFINE_DRIVER_ALL(PREFIX, NAME, DESCRIPTION, MODES, COUNT)                                        \
	static const mdrv_driver PREFIX##_driver = {MDRV_ABI_VERSION,      NAME,           DESCRIPTION,          \
						    PREFIX##_probe,        PREFIX##_open,  PREFIX##_get_format,  \
						    PREFIX##_start,        PREFIX##_next_frame, PREFIX##_stop, \
						    PREFIX##_close,        PREFIX##_check, MODES, COUNT};       \
	MDRV_ENTRY_LINKAGE __attribute__((visibility("default"))) const mdrv_driver *mdrv_entry(void)        \
	{                                                                                                    \
		return &PREFIX##_driver;                                                                     \
	}
#define MDRV_DEFINE_DRIVER_WITH(PREFIX, NAME, DESCRIPTION, MODES) \
	MDRV_DEFINE_DRIVER_ALL(PREFIX, NAME, DESCRIPTION, MODES, NULL)
/* A plugin without modes() (mocapd --probe lists its devices without modes). */
#define MDRV_DEFINE_DRIVER(PREFIX, NAME, DESCRIPTION) MDRV_DEFINE_DRIVER_WITH(PREFIX, NAME, DESCRIPTION, NULL)
/* A plugin with PREFIX_modes. */
#define MDRV_DEFINE_DRIVER_MODES(PREFIX, NAME, DESCRIPTION)                                                  \
	MDRV_DEFINE_DRIVER_WITH(PREFIX, NAME, DESCRIPTION, PREFIX##_modes)
/* A plugin of recordings with PREFIX_frame_count (and no modes()). */
#define MDRV_DEFINE_DRIVER_COUNT(PREFIX, NAME, DESCRIPTION)                                                  \
	MDRV_DEFINE_DRIVER_ALL(PREFIX, NAME, DESCRIPTION, NULL, PREFIX##_frame_count)

#ifdef __cplusplus
}
#endif

#endif
