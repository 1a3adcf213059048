#include "actor.h"

#include "log.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* A name is one path component: letters, digits, '-', '_' and '.', not
 * starting with '.', at most 64 bytes (no way out of actor_dir). */
static bool valid_name(const char *name)
{
	size_t n = strlen(name);
	if (n == 0 || n > 64 || name[0] == '.')
		return false;
	for (size_t i = 0; i < n; i++) {
		char c = name[i];
		if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' ||
		      c == '_' || c == '.'))
			return false;
	}
	return true;
}

int mcd_actor_save(mcd_pipeline *p, const mcd_config *cfg, const char *name, char *msg, size_t cap)
{
	if (!valid_name(name)) {
		snprintf(msg, cap, "'%s' is not a name (1-64 of A-Z a-z 0-9 - _ ., not starting with '.')",
			 name);
		return -1;
	}
	mc_model *actor = malloc(sizeof(*actor));
	if (!actor) {
		snprintf(msg, cap, "out of memory");
		return -1;
	}
	int rc = -1;
	char path[PATH_MAX + 80];
	if (!mcd_pipeline_actor(p, actor)) {
		snprintf(msg, cap, "no actor yet (the tracker is off, or has not calibrated the actor's "
				   "colours: state initialising, or no calibrate_colors)");
		goto out;
	}
	if (mkdir(cfg->tracker.actor_dir, 0750) < 0 && errno != EEXIST) {
		snprintf(msg, cap, "%s: %s ([tracker] actor_dir)", cfg->tracker.actor_dir, strerror(errno));
		goto out;
	}
	snprintf(path, sizeof(path), "%s/%s.json", cfg->tracker.actor_dir, name);
	mc_err err = {{0}};
	if (mc_model_save(actor, path, &err) < 0) {
		snprintf(msg, cap, "%s", err.msg);
		goto out;
	}
	snprintf(msg, cap, "saved actor %s to %s; load it with [tracker] actor = %s", name, path, path);
	mcd_info("%s", msg);
	rc = 0;
out:
	free(actor);
	return rc;
}
