#include "frame_size.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int whole_ratio(int big, int small)
{
	return small > 0 && big % small == 0 ? big / small : 0;
}

int mcd_frame_to_rig_scale(int fw, int fh, int rw, int rh, double *to_rig)
{
	if (fw <= 0 || fh <= 0 || rw <= 0 || rh <= 0)
		return 0;
	int up = whole_ratio(fw, rw), down = whole_ratio(rw, fw);
	if (up && whole_ratio(fh, rh) == up) {
		*to_rig = 1.0 / up;
		return 1;
	}
	if (down && whole_ratio(rh, fh) == down) {
		*to_rig = down;
		return 1;
	}
	return 0;
}

double mcd_frame_to_rig_coord(double u, double to_rig)
{
	return (u + 0.5) * to_rig - 0.5;
}

void mcd_frame_size_explain(int fw, int fh, const mc_camera *rc, const char *rig_path, char *buf, size_t cap)
{
	const char *base = strrchr(rig_path, '/');
	snprintf(buf, cap,
		 "%dx%d frames, but rig camera '%s' (%s) is calibrated at %dx%d: calibrate at %dx%d, or use "
		 "%dx%d times a whole number (mocapd --probe lists the sizes)",
		 fw, fh, rc->name, base ? base + 1 : rig_path, rc->width, rc->height, fw, fh, rc->width,
		 rc->height);
}

/* The section's width and height keys as integers; false if not both. */
static bool configured_size(const mcd_camera_config *cam, int *w, int *h)
{
	const mcd_kv *kw = mcd_camera_config_find(cam, "width");
	const mcd_kv *kh = mcd_camera_config_find(cam, "height");
	if (!kw || !kh)
		return false;
	char *end;
	*w = (int)strtol(kw->value, &end, 10);
	if (*end)
		return false;
	*h = (int)strtol(kh->value, &end, 10);
	return !*end; /* a bad value is the driver's check to report */
}

int mcd_frame_size_check(const mcd_config *cfg, const mc_rig *rig, const int *cam_to_rig, mc_err *err)
{
	size_t len = 0;
	int bad = 0, untold = 0;
	err->msg[0] = 0;
	for (int c = 0; c < cfg->ncams; c++) {
		const mcd_camera_config *cam = &cfg->cams[c];
		int w, h, r = cam_to_rig[c];
		double scale;
		if (r < 0 || r >= rig->ncams || !configured_size(cam, &w, &h) ||
		    mcd_frame_to_rig_scale(w, h, rig->cams[r].width, rig->cams[r].height, &scale))
			continue;
		char why[400], line[600];
		mcd_frame_size_explain(w, h, &rig->cams[r], cfg->tracker.rig, why, sizeof(why));
		int n = snprintf(line, sizeof(line), "%s%s:%d: [camera %s] width, height: %s", bad++ ? "\n" : "",
				 cfg->file, mcd_camera_config_find(cam, "width")->line, cam->name, why);
		/* Every mismatch, as many as the message holds; then a count. */
		if (untold || n < 0 || (size_t)n + 40 >= sizeof(err->msg) - len) {
			untold++;
			continue;
		}
		memcpy(err->msg + len, line, (size_t)n + 1);
		len += (size_t)n;
	}
	if (untold)
		snprintf(err->msg + len, sizeof(err->msg) - len, "\n... and %d more camera%s like it", untold,
			 untold == 1 ? "" : "s");
	return bad ? -1 : 0;
}
