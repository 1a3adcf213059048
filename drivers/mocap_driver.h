/* mocap_driver.h: the one ABI between mocapd and its camera driver plugins.
 *
 * A plugin is a shared object `mocap-driver-NAME.so` that exports
 *
 *     const mocap_driver *mocap_driver_entry(void);
 *
 * The host checks `abi_version` against MOCAP_DRIVER_ABI_VERSION and refuses
 * a mismatch.  The host owns the threads: for each opened camera it calls
 * next_frame() in a loop on a capture thread of its own, giving the driver a
 * slot (memory in the camera's frame ring) to fill.  Drivers never allocate
 * frame memory the host must free, never call exit(), and report every
 * failure as a negative mocap_status with a message in `err`.
 *
 * Any change to a struct or function here bumps MOCAP_DRIVER_ABI_VERSION. */
#ifndef MOCAP_DRIVER_H
#define MOCAP_DRIVER_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define MOCAP_DRIVER_ABI_VERSION 1u
#define MOCAP_DRIVER_ENTRY_SYMBOL "mocap_driver_entry"

typedef enum {
	MOCAP_OK = 0,
	MOCAP_ERR_IO = -1,      /* transient or unknown I/O error; the host may retry */
	MOCAP_ERR_NODEV = -2,   /* the device is gone (unplugged); reopen later */
	MOCAP_ERR_TIMEOUT = -3, /* no frame within timeout_ms; not an error by itself */
	MOCAP_ERR_CONFIG = -4,  /* bad or missing config key; will not succeed on retry */
	MOCAP_ERR_FORMAT = -5,  /* unsupported format or size */
	MOCAP_ERR_NOSPACE = -6, /* the frame does not fit the slot's capacity */
	MOCAP_ERR_END = -7,     /* end of a finite stream (e.g. files without loop) */
} mocap_status;

typedef enum {
	MOCAP_FMT_NONE = 0,
	MOCAP_FMT_RGB24 = 1,   /* packed R, G, B bytes */
	MOCAP_FMT_GRAY8 = 2,
	MOCAP_FMT_YUYV = 3,    /* YUV 4:2:2, Y0 U Y1 V */
	MOCAP_FMT_MJPEG = 4,   /* one JPEG image per frame, bytesused is its size */
	MOCAP_FMT_BAYER_RGGB8 = 5,
	MOCAP_FMT_BAYER_GRBG8 = 6,
	MOCAP_FMT_BAYER_GBRG8 = 7,
	MOCAP_FMT_BAYER_BGGR8 = 8,
	MOCAP_FMT_DEPTH16 = 9, /* uint16 millimetres, 0 = no reading */
} mocap_pixfmt;

typedef struct {
	uint32_t pixfmt;  /* mocap_pixfmt */
	uint32_t width, height;
	uint32_t stride;  /* bytes per row; 0 for compressed formats */
	double fps;       /* nominal; 0 if unknown or free-running */
	size_t max_bytes; /* the largest frame the driver can deliver */
} mocap_format;

enum {
	MOCAP_FRAME_CORRUPT = 1u << 0, /* the driver knows the data is damaged */
	MOCAP_FRAME_SHORT = 1u << 1,   /* fewer bytes than the format needs */
};

/* A slot the host gives to next_frame(). The driver writes into data (at most
 * capacity bytes) and fills the other fields. */
typedef struct {
	uint8_t *data;
	size_t capacity;
	size_t bytesused;
	uint64_t timestamp_ns; /* CLOCK_MONOTONIC, as close to exposure as possible */
	uint64_t sequence;     /* the driver's own frame counter */
	uint32_t flags;        /* MOCAP_FRAME_* */
	mocap_format format;   /* of this frame */
} mocap_frame;

enum { MOCAP_LOG_ERROR = 0, MOCAP_LOG_WARN = 1, MOCAP_LOG_INFO = 2, MOCAP_LOG_DEBUG = 3 };

/* What the host offers a driver. */
typedef struct {
	void *ctx;
	/* The value of `key` in this camera's config section, or NULL.  The
	 * host reports keys no driver call asked for as config errors; asking
	 * for "prefix.*" (returns NULL) claims every key starting with
	 * "prefix." as read, for keys the driver uses later. */
	const char *(*config_get)(void *ctx, const char *key);
	void (*log)(void *ctx, int level, const char *msg);
} mocap_host;

typedef struct {
	char id[128];       /* what the config's `device` key takes to select it */
	char name[128];     /* human-readable model name */
	char bus_info[128]; /* stable physical location, e.g. usb-0000:00:14.0-2 */
	char serial[64];    /* empty if unknown */
} mocap_device_info;

typedef struct mocap_driver {
	uint32_t abi_version; /* MOCAP_DRIVER_ABI_VERSION */
	const char *name;     /* "v4l2", "files", ... */
	const char *description;

	/* Lists up to `max` devices; returns how many were found (>= 0) or a
	 * negative mocap_status with a message. */
	int (*probe)(const mocap_host *host, mocap_device_info *out, int max, char *err, size_t errlen);
	/* Opens the device selected by the config section. NULL on error. */
	void *(*open)(const mocap_host *host, char *err, size_t errlen);
	/* The format frames will have after start(). */
	int (*get_format)(void *dev, mocap_format *fmt, char *err, size_t errlen);
	int (*start)(void *dev, char *err, size_t errlen);
	/* Waits up to timeout_ms for the next frame and copies it into slot.
	 * Returns MOCAP_OK, MOCAP_ERR_TIMEOUT, MOCAP_ERR_END or an error. */
	int (*next_frame)(void *dev, mocap_frame *slot, int timeout_ms, char *err, size_t errlen);
	void (*stop)(void *dev);
	void (*close)(void *dev);
} mocap_driver;

typedef const mocap_driver *(*mocap_driver_entry_fn)(void);

static inline const char *mocap_pixfmt_name(uint32_t pixfmt)
{
	static const char *const names[] = {"none", "RGB24", "GRAY8", "YUYV", "MJPEG", "BAYER_RGGB8",
					    "BAYER_GRBG8", "BAYER_GBRG8", "BAYER_BGGR8", "DEPTH16"};
	return pixfmt < sizeof(names) / sizeof(names[0]) ? names[pixfmt] : "unknown";
}

#ifdef __cplusplus
}
#endif

#endif
