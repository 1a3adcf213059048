/* mocap-driver-sim: a synthetic camera that renders the body model, driven
 * by motion capture, through a calibrated rig camera.
 *
 * Each frame: the BVH skeleton's pose at the frame's motion time gives the
 * positions of the docs/CONVENTIONS.md joints (core/body/mc_bvh.h documents the mapping of
 * both CMU namings), scaled to the actor's height and expressed relative to
 * the BVH Head joint.  The egocentric model's root (the head) is fixed to
 * the rig at model->rig_from_root, so those positions are carried into the
 * rig frame through it; inverse kinematics (core/body/mc_ik.h) poses the model on
 * them, with bone lengths fitted once from the BVH rest pose; the image is
 * the model's image formation (mc_ray_render_rgb, thesis eq. 4.10 and 5.5)
 * along every pixel's ray, over a uniform background.  Pixels outside the
 * lens' valid field of view are black.
 *
 * Config keys:
 *   bvh       BVH file of a CMU skeleton (required)
 *   rig       rig JSON file (required); must be egocentric
 *   model     body model JSON (default config/models/default.json, relative
 *             to the working directory); its root must be fixed
 *   camera    the rig camera to render (default: the first)
 *   width, height  output size (default: the camera's own); the rays
 *             sample the camera as mc_raytable_build describes
 *   rate      frames per second (default 30); 0 = as fast as rendered,
 *             motion time then advancing by 1/30 s per frame
 *   loop      true/false (default false): wrap around the motion
 *   height_m  the actor's height in metres (default 1.75)
 *   start     motion time of the first frame, seconds (default 0)
 *   epoch     CLOCK_MONOTONIC ns of the first frame (default: start()),
 *             as in the files driver: give every camera of a rig the same
 *             epoch and frame k of each carries the same timestamp
 *   background  #rrggbb (default #808080)
 *   hide_head true/false (default true): leave out the Gaussians of the
 *             root joint (the wearer's own head, right at the lenses), as
 *             the evaluation data does
 *
 * Frame k shows motion time start + k / rate (k counts on across loops)
 * with timestamp epoch + k / rate; it is not delivered before then.  The
 * renderer is the reference CPU model: at 256x256 a frame takes on the order
 * of a second, so for live rates ask for a smaller width and height. */
#include "drv_common.h"
#include "body/mc_bvh.h"
#include "energy/mc_energy.h"
#include "body/mc_ik.h"
#include "body/mc_model.h"
#include "geom/mc_rig.h"
#include "mdrv.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define DRV "sim"
#define DEFAULT_MODEL "config/models/default.json"

typedef struct {
	const mdrv_host *host;
	mc_bvh bvh;
	int bvh_index[MC_BVH_CMU_JOINTS];
	double metres_per_unit;
	mc_model model;
	mc_rig rig;
	int cam;
	mc_raytable rays;
	int ik_joint[MC_BVH_CMU_JOINTS]; /* model joint of each mapped joint, or -1 */
	double pose[MC_MAX_DOF];          /* warm start of the next solve */
	double background[3];
	bool hide_head;
	double rate, start_s;
	bool loop, epoch_given;
	uint64_t epoch_ns;
	mdrv_format fmt;
	bool started;
	uint64_t k; /* frames delivered since start() */
} sim_dev;

/* ---- config ---- */

static int parse_colour(const char *s, double rgb[3])
{
	unsigned v;
	char tail;
	if (!s || s[0] != '#' || strlen(s) != 7 || sscanf(s + 1, "%6x%c", &v, &tail) != 1)
		return -1;
	rgb[0] = ((v >> 16) & 255) / 255.0;
	rgb[1] = ((v >> 8) & 255) / 255.0;
	rgb[2] = (v & 255) / 255.0;
	return 0;
}

static int load_inputs(sim_dev *d, char *err, size_t errlen)
{
	const mdrv_host *h = d->host;
	mc_err e;
	const char *bvh = drv_cfg_str(h, "bvh"), *rig = drv_cfg_str(h, "rig"), *model = drv_cfg_str(h, "model");
	if (!bvh)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config key 'bvh' is required (a CMU BVH file)", DRV);
	if (!rig)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config key 'rig' is required (a rig JSON file)", DRV);
	if (!model)
		model = DEFAULT_MODEL;
	if (mc_bvh_load(bvh, &d->bvh, &e) != 0)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config key 'bvh': %s", DRV, e.msg);
	if (d->bvh.nframes == 0)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config key 'bvh': %s has no frames", DRV, bvh);
	if (mc_bvh_map_cmu(&d->bvh, d->bvh_index, &e) != 0)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config key 'bvh': %s: %s", DRV, bvh, e.msg);
	if (mc_rig_load(rig, &d->rig, &e) != 0)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config key 'rig': %s", DRV, e.msg);
	if (d->rig.kind != MC_RIG_EGOCENTRIC)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG,
				"%s: config key 'rig': %s is outside-in; the sim driver renders egocentric rigs only", DRV,
				rig);
	if (mc_model_load(model, &d->model, &e) != 0)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config key 'model': %s", DRV, e.msg);
	if (d->model.root_free)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG,
				"%s: config key 'model': %s has a free root; an egocentric rig needs a fixed one", DRV, model);
	const char *cam = drv_cfg_str(h, "camera");
	d->cam = cam ? mc_rig_find(&d->rig, cam) : 0;
	if (d->cam < 0)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config key 'camera': rig %s has no camera '%s'", DRV,
				rig, cam);
	return MDRV_OK;
}

static int parse_options(sim_dev *d, unsigned *width, unsigned *height, double *height_m, char *err, size_t errlen)
{
	const mdrv_host *h = d->host;
	const mc_camera *cam = &d->rig.cams[d->cam];
	*width = (unsigned)cam->width;
	*height = (unsigned)cam->height;
	*height_m = 1.75;
	d->rate = 30;
	d->hide_head = true;
	int rc;
	if ((rc = drv_cfg_uint(h, DRV, "width", 1, 8192, width, err, errlen)) != MDRV_OK ||
	    (rc = drv_cfg_uint(h, DRV, "height", 1, 8192, height, err, errlen)) != MDRV_OK ||
	    (rc = drv_cfg_double(h, DRV, "rate", 0, 1000, &d->rate, err, errlen)) != MDRV_OK ||
	    (rc = drv_cfg_bool(h, DRV, "loop", &d->loop, err, errlen)) != MDRV_OK ||
	    (rc = drv_cfg_double(h, DRV, "height_m", 0.5, 2.5, height_m, err, errlen)) != MDRV_OK ||
	    (rc = drv_cfg_double(h, DRV, "start", 0, 1e6, &d->start_s, err, errlen)) != MDRV_OK ||
	    (rc = drv_cfg_bool(h, DRV, "hide_head", &d->hide_head, err, errlen)) != MDRV_OK ||
	    (rc = drv_cfg_monotonic_ns(h, DRV, "epoch", &d->epoch_ns, &d->epoch_given, err, errlen)) != MDRV_OK)
		return rc;
	const char *bg = drv_cfg_str(h, "background");
	d->background[0] = d->background[1] = d->background[2] = 0.5;
	if (bg && parse_colour(bg, d->background) != 0)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config key 'background': expected #rrggbb, got '%s'",
				DRV, bg);
	return MDRV_OK;
}

/* ---- motion ---- */

/* Mapped joints of frame f of `bvh` (d->bvh, or its rest pose), in the rig frame. */
static void targets_at(const sim_dev *d, const mc_bvh *bvh, int f, mc_ik_target *t, int *n)
{
	mc_vec3 head[MC_BVH_CMU_JOINTS];
	mc_bvh_joints_in_head(bvh, d->bvh_index, f, d->metres_per_unit, head);
	*n = 0;
	for (int i = 0; i < MC_BVH_CMU_JOINTS; i++)
		if (d->ik_joint[i] >= 0)
			t[(*n)++] = (mc_ik_target){.joint = d->ik_joint[i],
						   .position = mc_xform_apply(d->model.rig_from_root, head[i]),
						   .weight = 1.0};
}

/* Bone lengths from the standing rest pose of the BVH skeleton. */
static int fit_actor(sim_dev *d, double height_m, char *err, size_t errlen)
{
	double rest = mc_bvh_rest_height(&d->bvh);
	if (!(rest > 0))
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: config key 'bvh': the skeleton has no height", DRV);
	d->metres_per_unit = height_m / rest;
	for (int i = 0; i < MC_BVH_CMU_JOINTS; i++)
		d->ik_joint[i] = mc_model_find_joint(&d->model, mc_bvh_cmu_joint_name(i));
	mc_bvh rest_pose = d->bvh;
	rest_pose.nframes = 0; /* no values: every channel 0 */
	mc_ik_target t[MC_BVH_CMU_JOINTS];
	int n;
	targets_at(d, &rest_pose, 0, t, &n);
	if (n < 8)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: the model has only %d of the mapped joints", DRV, n);
	mc_ik_fit_bone_scale(&d->model, t, n);
	mc_model_rest_pose(&d->model, d->pose);
	return MDRV_OK;
}

/* Poses the model on BVH frame f (warm-started from the previous frame). */
static int pose_at(sim_dev *d, int f, char *err, size_t errlen)
{
	mc_ik_target t[MC_BVH_CMU_JOINTS];
	int n;
	targets_at(d, &d->bvh, f, t, &n);
	mc_ik_options o;
	mc_ik_options_default(&o);
	o.fit_bone_scale = false;
	o.fit_root = false;
	o.iterations = 30;
	mc_err e;
	if (mc_ik_solve(&d->model, d->pose, t, n, &o, &e) < 0)
		return drv_errf(err, errlen, MDRV_ERR_IO, "%s: inverse kinematics at BVH frame %d: %s", DRV, f, e.msg);
	return MDRV_OK;
}

static void render(const sim_dev *d, uint8_t *rgb)
{
	mc_fk fk;
	mc_model_fk(&d->model, d->pose, &fk);
	mc_scene scene;
	mc_scene_from_model(&d->model, &fk, &scene);
	/* The wearer's own head is left out, as in the evaluation data: it
	 * sits right at the lenses and would hide the body behind a blur. */
	double albedo[MC_MAX_GAUSSIANS][3];
	int n = 0;
	for (int q = 0; q < scene.n; q++) {
		if (d->model.gauss[q].joint == 0 && d->hide_head)
			continue;
		scene.mu[n] = scene.mu[q];
		scene.sigma[n] = scene.sigma[q];
		scene.c[n] = scene.c[q];
		memcpy(scene.hsv[n], scene.hsv[q], sizeof(scene.hsv[n]));
		memcpy(albedo[n], d->model.gauss[q].rgb, sizeof(albedo[n]));
		n++;
	}
	scene.n = n;
	const mc_raytable *rt = &d->rays;
	for (int k = 0; k < rt->width * rt->height; k++, rgb += 3) {
		if (!rt->valid[k]) {
			rgb[0] = rgb[1] = rgb[2] = 0;
			continue;
		}
		double c[3];
		mc_ray_render_rgb(&scene, (const double(*)[3])albedo, rt->origin, rt->dir[k], d->background, c);
		for (int ch = 0; ch < 3; ch++)
			rgb[ch] = (uint8_t)lround(fmin(fmax(c[ch], 0.0), 1.0) * 255.0);
	}
}

/* ---- the ABI ---- */

static int sim_probe(const mdrv_host *host, mdrv_device_info *out, int max, char *err, size_t errlen)
{
	(void)host, (void)out, (void)max, (void)err, (void)errlen;
	return 0;
}

static void sim_close(void *dev)
{
	sim_dev *d = dev;
	if (!d)
		return;
	mc_bvh_free(&d->bvh);
	mc_raytable_free(&d->rays);
	free(d);
}

static void *sim_open(const mdrv_host *host, char *err, size_t errlen)
{
	sim_dev *d = calloc(1, sizeof(*d));
	if (!d) {
		drv_errf(err, errlen, MDRV_ERR_IO, "%s: out of memory", DRV);
		return NULL;
	}
	d->host = host;
	unsigned w, h;
	double height_m;
	mc_err e;
	int rc = load_inputs(d, err, errlen);
	if (rc == MDRV_OK)
		rc = parse_options(d, &w, &h, &height_m, err, errlen);
	if (rc == MDRV_OK)
		rc = fit_actor(d, height_m, err, errlen);
	if (rc != MDRV_OK)
		goto fail;
	if (mc_raytable_build(&d->rig.cams[d->cam], (int)w, (int)h, &d->rays, &e) != 0) {
		rc = drv_errf(err, errlen, MDRV_ERR_CONFIG, "%s: camera '%s' at %ux%u: %s", DRV,
			      d->rig.cams[d->cam].name, w, h, e.msg);
		goto fail;
	}
	d->fmt = (mdrv_format){.pixfmt = MC_PIXFMT_RGB24, .width = w, .height = h, .stride = w * 3, .fps = d->rate,
				.max_bytes = (size_t)w * h * 3};
	drv_logf(host, MDRV_LOG_INFO, "%s: %d BVH frames at %.0f Hz, camera '%s' at %ux%u, %g fps%s", DRV,
		 d->bvh.nframes, 1.0 / d->bvh.frame_time, d->rig.cams[d->cam].name, w, h, d->rate,
		 d->loop ? ", looping" : "");
	return d;
fail:
	sim_close(d);
	return drv_open_failed(host, rc);
}

static int sim_get_format(void *dev, mdrv_format *fmt, char *err, size_t errlen)
{
	(void)err, (void)errlen;
	*fmt = ((sim_dev *)dev)->fmt;
	return MDRV_OK;
}

static int sim_start(void *dev, char *err, size_t errlen)
{
	(void)err, (void)errlen;
	sim_dev *d = dev;
	if (!d->epoch_given)
		d->epoch_ns = mc_now_ns();
	d->k = 0;
	d->started = true;
	return MDRV_OK;
}

static void sim_stop(void *dev) { ((sim_dev *)dev)->started = false; }

static int sim_next_frame(void *dev, mdrv_frame *slot, int timeout_ms, char *err, size_t errlen)
{
	sim_dev *d = dev;
	if (!d->started)
		return drv_errf(err, errlen, MDRV_ERR_IO, "%s: next_frame before start", DRV);
	double period = d->rate > 0 ? 1.0 / d->rate : 1.0 / 30;
	double duration = d->bvh.nframes * d->bvh.frame_time;
	double t = d->start_s + (double)d->k * period;
	if (d->loop)
		t = fmod(t, duration);
	else if (t > duration - d->bvh.frame_time * 0.5)
		return drv_errf(err, errlen, MDRV_ERR_END, "%s: end of the motion (%.2f s)", DRV, duration);
	if (slot->capacity < d->fmt.max_bytes)
		return drv_errf(err, errlen, MDRV_ERR_NOSPACE, "%s: a %ux%u RGB frame needs %zu bytes, the slot holds %zu",
				DRV, d->fmt.width, d->fmt.height, d->fmt.max_bytes, slot->capacity);
	uint64_t ts = 0;
	if (d->rate > 0) {
		ts = d->epoch_ns + (uint64_t)((double)d->k * 1e9 / d->rate + 0.5);
		uint64_t now = mc_now_ns();
		if (ts > now && timeout_ms >= 0 && ts - now > (uint64_t)timeout_ms * 1000000ull) {
			mc_sleep_until_ns(now + (uint64_t)timeout_ms * 1000000ull);
			return drv_errf(err, errlen, MDRV_ERR_TIMEOUT, "%s: next frame due later", DRV);
		}
	}
	int f = (int)lround(t / d->bvh.frame_time);
	int rc = pose_at(d, f, err, errlen);
	if (rc != MDRV_OK)
		return rc;
	render(d, slot->data);
	if (d->rate > 0)
		mc_sleep_until_ns(ts); /* rendered ahead of time: wait for the frame's moment */
	else
		ts = mc_now_ns();
	slot->bytesused = d->fmt.max_bytes;
	slot->timestamp_ns = ts;
	slot->sequence = d->k++;
	slot->flags = 0;
	slot->format = d->fmt;
	return MDRV_OK;
}

/* The keys and the inputs they name (BVH, rig, model), as open() reads
 * them; nothing is rendered. */
static int sim_check(const mdrv_host *host, char *err, size_t errlen)
{
	sim_dev *d = calloc(1, sizeof(*d));
	if (!d)
		return drv_errf(err, errlen, MDRV_ERR_IO, "%s: out of memory", DRV);
	d->host = host;
	unsigned w, h;
	double height_m;
	int rc = load_inputs(d, err, errlen);
	if (rc == MDRV_OK)
		rc = parse_options(d, &w, &h, &height_m, err, errlen);
	sim_close(d);
	return rc;
}

MDRV_DEFINE_DRIVER(sim, DRV,
		   "renders the body model driven by a BVH file through a rig camera")
