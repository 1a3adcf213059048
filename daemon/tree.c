#include "tree.h"

#include <dirent.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static bool has_plugin(const char *dir)
{
	DIR *d = opendir(dir);
	if (!d)
		return false;
	bool found = false;
	struct dirent *e;
	while (!found && (e = readdir(d))) {
		size_t n = strlen(e->d_name);
		found = !strncmp(e->d_name, "mocap-driver-", 13) && n > 16 && !strcmp(e->d_name + n - 3, ".so");
	}
	closedir(d);
	return found;
}

bool mcd_tree_plugin_dir(const char *exe, char *out, size_t cap)
{
	char build[PATH_MAX];
	snprintf(build, sizeof build, "%s", exe);
	char *slash = strrchr(build, '/');
	if (!slash)
		return false;
	*slash = 0; /* <build>/bin */
	slash = strrchr(build, '/');
	if (!slash || strcmp(slash + 1, "bin") != 0)
		return false;
	*slash = 0; /* <build> */
	char probe[PATH_MAX + 32];
	/* An installed /usr/bin/mocapd has /usr/drivers nowhere and no
	 * daemon/main.c above it: only a checkout matches. */
	snprintf(probe, sizeof probe, "%s/../daemon/main.c", build);
	if (access(probe, R_OK) != 0)
		return false;
	snprintf(probe, sizeof probe, "%s/drivers", build);
	if (!has_plugin(probe))
		return false;
	return (size_t)snprintf(out, cap, "%s", probe) < cap;
}

bool mcd_tree_plugin_dir_self(char *out, size_t cap)
{
	char exe[PATH_MAX];
	if (!realpath("/proc/self/exe", exe))
		return false;
	return mcd_tree_plugin_dir(exe, out, cap);
}
