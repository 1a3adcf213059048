/* plugin: loads camera driver plugins, mocap-driver-NAME.so, from one
 * trusted directory.
 *
 * Trust rule (what mcd_path_trusted checks).  A plugin runs inside the
 * daemon with the daemon's privileges, so nobody but root and the daemon's
 * own user may be able to replace it.  For the plugin file, the plugin
 * directory and every directory above it up to "/":
 *   - the owner must be root (uid 0) or the daemon's effective user;
 *   - it must not be writable by others (S_IWOTH), except a directory above
 *     the plugin directory with the sticky bit set (e.g. /tmp), where others
 *     cannot rename or delete entries they do not own;
 *   - it must not be writable by its group (S_IWGRP) unless the group is
 *     root's (gid 0) or the daemon's effective group;
 *   - the plugin itself must be a regular file, not a symbolic link
 *     (the directory path may contain links; they are resolved first and
 *     the resolved path is checked).
 * The plugin is opened once (O_NOFOLLOW), checked with fstat on that
 * descriptor and loaded from /proc/self/fd/N, so that the file checked is
 * the file loaded.
 *
 * A plugin must export mdrv_entry() returning a descriptor whose
 * abi_version is one this host speaks (MDRV_ABI_MIN_VERSION to
 * MDRV_ABI_VERSION) and whose function pointers are all set; anything else
 * is refused with a message saying why. */
#ifndef MCD_PLUGIN_H
#define MCD_PLUGIN_H

#include "base/mc_error.h"
#include "base/mc_limits.h"
#include "config.h"
#include "mdrv.h"

#include <stdbool.h>
#include <sys/stat.h>
#include <sys/types.h>

typedef struct {
	char name[64];    /* driver name as asked for */
	char path[4096];  /* resolved path of the .so */
	void *handle;     /* dlopen handle */
	int fd;           /* the descriptor it was loaded from, kept for symbolizers */
	const mdrv_driver *driver;
} mcd_plugin;

/* Checks one path (file or directory) against the trust rule above for the
 * given user and group.  `is_dir_above` selects the sticky-bit exception.
 * Returns 0, or -1 with err saying which rule failed. */
int mcd_path_trusted(const char *path, const struct stat *st, uid_t uid, gid_t gid, bool is_dir_above,
		     mc_err *err);

/* Checks dir and every directory above it. */
int mcd_dir_trusted(const char *dir, uid_t uid, gid_t gid, mc_err *err);

/* Loads <dir>/mocap-driver-<name>.so for the daemon running as uid/gid
 * (normally geteuid(), getegid()). Returns 0 or -1 with err. */
int mcd_plugin_load(const char *dir, const char *name, uid_t uid, gid_t gid, mcd_plugin *out, mc_err *err);
void mcd_plugin_unload(mcd_plugin *p);
/* The frames an opened device will deliver (mdrv_driver.frame_count), or
 * 0 when not known: the driver says so, has no frame_count, or was built
 * for ABI 3 (its descriptor has no such member, which is not read). */
uint64_t mcd_driver_frame_count(const mdrv_driver *drv, void *dev);
/* Lets go of p but leaves its library loaded for the rest of the process:
 * for a short-lived process (mocapd --probe) that has started a camera
 * library.  Aravis, libcamera and OpenNI2 start threads and keep state
 * for the life of the process that their users cannot tear down; unloading
 * them under those threads crashes (libcamera), and allocations they keep
 * lose their library's name, which leak checkers' suppressions need. */
void mcd_plugin_keep(mcd_plugin *p);

/* The plugins of a daemon's cameras: each driver loaded once, however
 * many cameras use it. */
typedef struct {
	int n;
	mcd_plugin plugins[MC_MAX_CAMERAS];
} mcd_plugin_set;

/* The plugin of a camera's driver from cfg->plugin_dir, loaded for the
 * daemon's effective user and group on first use (and logged).  Errors
 * name the config line: "mocapd.conf:10: [camera a] driver: ...". */
const mcd_plugin *mcd_plugin_set_get(mcd_plugin_set *s, const mcd_config *cfg, const mcd_camera_config *cam,
				     mc_err *err);
void mcd_plugin_set_unload(mcd_plugin_set *s);

#endif
