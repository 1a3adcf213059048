#include "check.h"

#include "detector_thread.h"
#include "graph_source.h"
#include "log.h"
#include "network.h"
#include "pipeline.h"
#include "tracker_setup.h"

#include <limits.h>
#include <stdio.h>

/* --check: the rig, the model, the initial joints, the TCP token file, the
 * detector's model, the plugins and every camera's driver keys (checked by
 * the driver) are the parts of start-up that can be checked without
 * touching devices or OpenCL.  Each part is checked on its own and every
 * error is printed, not only the first.  Returns the exit status. */
static int nerrors;

static void report(const char *msg)
{
	mcd_error("%s", msg);
	nerrors++;
}

static void check_part(int rc, const mc_err *err)
{
	if (rc != 0)
		report(err->msg);
}

int mcd_check(const mcd_config *cfg, const char *config_path)
{
	mc_err err = {{0}};
	char where[PATH_MAX + 64];
	nerrors = 0;
	if (cfg->source.graph[0]) {
		check_part(mcd_graph_source_check(cfg, &err), &err);
	} else {
		if (cfg->tracker.enabled)
			check_part(mcd_tracking_check(cfg, &err), &err);
		char token[SRV_TOKEN_MAX];
		if (cfg->network.listen[0])
			check_part(mcd_network_read_token(cfg, token, sizeof(token), &err), &err);
		check_part(mcd_detector_check(&cfg->detector,
					      mcd_config_where(cfg, "detector", "model", where, sizeof(where)), &err),
			   &err);
		mcd_pipeline *p = mcd_pipeline_create(cfg, NULL, NULL, &err);
		if (!p)
			report(err.msg);
		else
			mcd_pipeline_check_cameras(p, report, &err);
		mcd_pipeline_destroy(p);
	}
	if (nerrors) {
		fprintf(stderr, "%s: %d error%s\n", config_path, nerrors, nerrors == 1 ? "" : "s");
		return 1;
	}
	printf("%s: ok\n", config_path);
	return 0;
}

