#include "cl_cache.h"

#include <errno.h>
#include <limits.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* Whether dir exists as a folder we may write, or can be made (with its
 * parents, 0700) in a folder we may write. */
static bool usable(const char *dir)
{
	struct stat st;
	if (stat(dir, &st) == 0)
		return S_ISDIR(st.st_mode) && access(dir, W_OK | X_OK) == 0;
	char parent[PATH_MAX];
	snprintf(parent, sizeof(parent), "%s", dir);
	char *slash = strrchr(parent, '/');
	if (!slash || slash == parent)
		return false;
	*slash = 0;
	if (!usable(parent))
		return false;
	return mkdir(dir, 0700) == 0 || errno == EEXIST;
}

/* A folder of our own under a shared one such as /tmp: made by us, ours,
 * not a link, nobody else may write into it. */
static bool private_dir(const char *dir)
{
	if (mkdir(dir, 0700) != 0 && errno != EEXIST)
		return false;
	struct stat st;
	return lstat(dir, &st) == 0 && S_ISDIR(st.st_mode) && st.st_uid == geteuid() && !(st.st_mode & 022);
}

static bool env_dir_usable(const char *var, const char *sub, char *path, size_t cap)
{
	const char *base = getenv(var);
	if (!base || base[0] != '/')
		return false;
	return (size_t)snprintf(path, cap, "%s%s", base, sub) < cap && usable(path);
}

int mcd_cl_cache_setup(char *note, size_t cap)
{
	note[0] = 0;
	char path[PATH_MAX];
	if (getenv("POCL_CACHE_DIR") || env_dir_usable("XDG_CACHE_HOME", "/pocl", path, sizeof(path)) ||
	    env_dir_usable("HOME", "/.cache/pocl", path, sizeof(path)))
		return 0; /* PoCL finds its own */
	const char *tmp = getenv("TMPDIR");
	char in_tmp[PATH_MAX];
	snprintf(in_tmp, sizeof(in_tmp), "%s/mocapd-pocl-%u", tmp && tmp[0] == '/' ? tmp : "/tmp", (unsigned)geteuid());
	/* /var/cache/mocapd only when the package made it (tmpfiles) and it
	 * is ours to write: mocapd makes no system folders itself. */
	bool var_cache = access("/var/cache/mocapd", W_OK | X_OK) == 0 && usable("/var/cache/mocapd/pocl");
	const char *dir = var_cache ? "/var/cache/mocapd/pocl" : private_dir(in_tmp) ? in_tmp : NULL;
	const char *home = getenv("HOME");
	if (!dir) {
		snprintf(note, cap,
			 "no folder for the OpenCL (PoCL) kernel cache: POCL_CACHE_DIR and XDG_CACHE_HOME are unset, "
			 "HOME (%s) has no writable .cache, and neither /var/cache/mocapd nor %s is writable; set "
			 "POCL_CACHE_DIR to a folder this user may write",
			 home ? home : "unset", in_tmp);
		return -1;
	}
	setenv("POCL_CACHE_DIR", dir, 1);
	snprintf(note, cap, "OpenCL kernel cache: POCL_CACHE_DIR=%s (HOME %s has no writable .cache)", dir,
		 home ? home : "unset");
	return 0;
}
