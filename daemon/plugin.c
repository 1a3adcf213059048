#include "plugin.h"

#include "log.h"

#include <ctype.h>
#include <dirent.h>
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static const char *kind_of(const struct stat *st)
{
	return S_ISDIR(st->st_mode) ? "directory" : "file";
}

int mcd_path_trusted(const char *path, const struct stat *st, uid_t uid, gid_t gid, bool is_dir_above, mc_err *err)
{
	if (st->st_uid != 0 && st->st_uid != uid)
		return mc_err_set(err,
				  "%s: %s owned by uid %u, which is neither root nor the daemon's user (uid %u); "
				  "refused",
				  path, kind_of(st), (unsigned)st->st_uid, (unsigned)uid);
	if (st->st_mode & S_IWOTH) {
		bool sticky_dir = is_dir_above && S_ISDIR(st->st_mode) && (st->st_mode & S_ISVTX);
		if (!sticky_dir)
			return mc_err_set(err, "%s: %s writable by others (mode %04o); refused", path, kind_of(st),
					  (unsigned)(st->st_mode & 07777));
	}
	if ((st->st_mode & S_IWGRP) && st->st_gid != 0 && st->st_gid != gid)
		return mc_err_set(err,
				  "%s: %s writable by group gid %u, which is neither root's nor the daemon's group "
				  "(gid %u) (mode %04o); refused",
				  path, kind_of(st), (unsigned)st->st_gid, (unsigned)gid, (unsigned)(st->st_mode & 07777));
	return 0;
}

int mcd_dir_trusted(const char *dir, uid_t uid, gid_t gid, mc_err *err)
{
	char path[PATH_MAX];
	if (!realpath(dir, path))
		return mc_err_set(err, "%s: %s", dir, strerror(errno));
	struct stat st;
	if (stat(path, &st) != 0)
		return mc_err_set(err, "%s: %s", path, strerror(errno));
	if (!S_ISDIR(st.st_mode))
		return mc_err_set(err, "%s: not a directory", path);
	if (mcd_path_trusted(path, &st, uid, gid, false, err))
		return -1;
	/* Every directory above: whoever can write there can swap the whole
	 * plugin directory for another. */
	for (;;) {
		char *slash = strrchr(path, '/');
		if (!slash)
			break;
		if (slash == path) {
			if (path[1] == 0)
				break;
			path[1] = 0;
		} else
			*slash = 0;
		if (stat(path, &st) != 0)
			return mc_err_set(err, "%s: %s", path, strerror(errno));
		if (mcd_path_trusted(path, &st, uid, gid, true, err))
			return mc_err_prefix(err, "plugin directory %s", dir);
	}
	return 0;
}

static bool valid_driver_name(const char *name)
{
	if (!*name || strlen(name) > 48)
		return false;
	for (const char *c = name; *c; c++)
		if (!isalnum((unsigned char)*c) && *c != '_' && *c != '-')
			return false;
	return true;
}

/* "files, sim" : the drivers present in dir, to help with a typo. */
static void list_drivers(const char *dir, char *buf, size_t cap)
{
	buf[0] = 0;
	DIR *d = opendir(dir);
	if (!d)
		return;
	size_t len = 0;
	struct dirent *e;
	while ((e = readdir(d))) {
		const char *n = e->d_name;
		size_t nl = strlen(n);
		if (strncmp(n, "mocap-driver-", 13) != 0 || nl < 17 || strcmp(n + nl - 3, ".so") != 0)
			continue;
		int w = snprintf(buf + len, cap - len, "%s%.*s", len ? ", " : "", (int)(nl - 16), n + 13);
		if (w < 0 || (size_t)w >= cap - len)
			break;
		len += (size_t)w;
	}
	closedir(d);
}

static int check_descriptor(const mdrv_driver *drv, const char *path, mc_err *err)
{
	if (!drv)
		return mc_err_set(err, "%s: mdrv_entry() returned NULL; refused", path);
	/* abi_version is the first member in every ABI version, so reading it
	 * is safe whatever the plugin was built against.  Versions from
	 * MDRV_ABI_MIN_VERSION on only appended optional members, which the
	 * host reads from plugins that have them (mcd_driver_frame_count). */
	if (drv->abi_version < MDRV_ABI_MIN_VERSION || drv->abi_version > MDRV_ABI_VERSION)
		return mc_err_set(err,
				  "%s: built for driver ABI version %u, but this mocapd speaks versions %u to %u; "
				  "rebuild the plugin against this mocapd's mdrv.h",
				  path, (unsigned)drv->abi_version, (unsigned)MDRV_ABI_MIN_VERSION,
				  (unsigned)MDRV_ABI_VERSION);
	const char *missing = !drv->name         ? "name"
			      : !drv->open       ? "open"
			      : !drv->get_format ? "get_format"
			      : !drv->start      ? "start"
			      : !drv->next_frame ? "next_frame"
			      : !drv->stop       ? "stop"
			      : !drv->close      ? "close"
						 : NULL;
	if (missing)
		return mc_err_set(err, "%s: the driver descriptor has no '%s'; refused", path, missing);
	return 0;
}

/* Opens <real_dir>/mocap-driver-<name>.so without following a link and
 * checks that descriptor; sets out->path.  Returns the fd or -1 with err. */
static int open_checked(const char *real_dir, const char *name, uid_t uid, gid_t gid, mcd_plugin *out, mc_err *err)
{
	int dfd = open(real_dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
	if (dfd < 0)
		return mc_err_set(err, "plugin directory %s: %s", real_dir, strerror(errno));
	char file[128];
	snprintf(file, sizeof(file), "mocap-driver-%s.so", name);
	if ((size_t)snprintf(out->path, sizeof(out->path), "%.3900s/%s", real_dir, file) >= sizeof(out->path)) {
		close(dfd);
		return mc_err_set(err, "plugin directory %s: path too long", real_dir);
	}
	int fd = openat(dfd, file, O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
	int open_errno = errno;
	close(dfd);
	if (fd < 0) {
		if (open_errno == ELOOP)
			return mc_err_set(err, "%s: is a symbolic link; plugins must be regular files; refused",
					  out->path);
		if (open_errno == ENOENT) {
			char avail[512];
			list_drivers(real_dir, avail, sizeof(avail));
			return mc_err_set(err, "driver '%s': no %s in %s (drivers there: %s)", name, file, real_dir,
					  avail[0] ? avail : "none");
		}
		return mc_err_set(err, "%s: %s", out->path, strerror(open_errno));
	}
	struct stat st;
	if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
		close(fd);
		return mc_err_set(err, "%s: not a regular file; refused", out->path);
	}
	if (mcd_path_trusted(out->path, &st, uid, gid, false, err)) {
		close(fd);
		return -1;
	}
	return fd;
}

/* Loads the very file that was checked (from its descriptor, not whatever
 * the path names now) and takes its driver descriptor. */
static int load_from_fd(int fd, mcd_plugin *out, mc_err *err)
{
	char fd_path[64];
	snprintf(fd_path, sizeof(fd_path), "/proc/self/fd/%d", fd);
	dlerror();
	void *handle = dlopen(fd_path, RTLD_NOW | RTLD_LOCAL);
	if (!handle) {
		const char *why = dlerror();
		return mc_err_set(err, "%s: cannot load: %s", out->path, why ? why : "unknown dlopen error");
	}
	mdrv_entry_fn entry;
	*(void **)&entry = dlsym(handle, MDRV_ENTRY_SYMBOL);
	if (!entry) {
		dlclose(handle);
		return mc_err_set(err, "%s: exports no %s(); not a mocapd driver plugin; refused", out->path,
				  MDRV_ENTRY_SYMBOL);
	}
	const mdrv_driver *drv = entry();
	if (check_descriptor(drv, out->path, err)) {
		dlclose(handle);
		return -1;
	}
	out->handle = handle;
	out->driver = drv;
	return 0;
}

int mcd_plugin_load(const char *dir, const char *name, uid_t uid, gid_t gid, mcd_plugin *out, mc_err *err)
{
	memset(out, 0, sizeof(*out));
	out->fd = -1;
	if (!valid_driver_name(name))
		return mc_err_set(err, "driver '%s': not a valid driver name (letters, digits, '_', '-')", name);
	char real_dir[PATH_MAX];
	if (!realpath(dir, real_dir))
		return mc_err_set(err, "plugin directory %s: %s", dir, strerror(errno));
	if (mcd_dir_trusted(real_dir, uid, gid, err))
		return -1;
	int fd = open_checked(real_dir, name, uid, gid, out, err);
	if (fd < 0)
		return -1;
	if (load_from_fd(fd, out, err)) {
		close(fd);
		return -1;
	}
	if (strcmp(out->driver->name, name) != 0)
		mcd_warn("%s: the driver calls itself '%s', not '%s'", out->path, out->driver->name, name);
	snprintf(out->name, sizeof(out->name), "%s", name);
	out->fd = fd;
	return 0;
}

uint64_t mcd_driver_frame_count(const mdrv_driver *drv, void *dev)
{
	uint64_t n = 0;
	if (drv->abi_version < 4 || !drv->frame_count) /* an ABI 3 descriptor ends before it */
		return 0;
	return drv->frame_count(dev, &n) == MDRV_OK ? n : 0;
}

void mcd_plugin_unload(mcd_plugin *p)
{
	if (p->handle)
		dlclose(p->handle);
	if (p->fd >= 0)
		close(p->fd);
	p->handle = NULL;
	p->fd = -1;
	p->driver = NULL;
}

void mcd_plugin_keep(mcd_plugin *p)
{
	/* The descriptor stays open too: the library was loaded as
	 * /proc/self/fd/N, and dlopen takes a later plugin opened on the same
	 * N for this one, already loaded (--probe then asked the first driver
	 * nine times: "the driver calls itself 'files', not 'gstreamer'"). */
	p->fd = -1;
	p->handle = NULL; /* stays mapped until the process exits */
	p->driver = NULL;
}

const mcd_plugin *mcd_plugin_set_get(mcd_plugin_set *s, const mcd_config *cfg, const mcd_camera_config *cam,
				     mc_err *err)
{
	for (int i = 0; i < s->n; i++)
		if (strcmp(s->plugins[i].name, cam->driver) == 0)
			return &s->plugins[i];
	if (s->n >= MC_MAX_CAMERAS) {
		mc_err_set(err, "%s:%d: [camera %s] driver: too many drivers", cfg->file, cam->driver_line, cam->name);
		return NULL;
	}
	mcd_plugin *pl = &s->plugins[s->n];
	if (mcd_plugin_load(cfg->plugin_dir, cam->driver, geteuid(), getegid(), pl, err)) {
		mc_err_prefix(err, "%s:%d: [camera %s] driver", cfg->file, cam->driver_line, cam->name);
		return NULL;
	}
	s->n++;
	mcd_info("driver %s: %s (%s)", cam->driver, pl->driver->description ? pl->driver->description : "", pl->path);
	return pl;
}

void mcd_plugin_set_unload(mcd_plugin_set *s)
{
	for (int i = 0; i < s->n; i++)
		mcd_plugin_unload(&s->plugins[i]);
	s->n = 0;
}
