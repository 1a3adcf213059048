/* mocap-track: tracks a recorded take again, offline, as fast as the
 * machine allows and at a budget of one's choosing, and writes the new
 * skeletons into the take as TAKE/poses-NAME.mcr (docs/RECORDING.md,
 * "Tracking a take again").
 *
 *   mocap-track [--iterations N] [--resolution N] [--name NAME] [--detector MODEL] [--quiet] TAKE_DIR
 *
 * The rig and the body model are the take's copies (the actor file when the
 * take has one); the tracker starts from the first skeleton recorded live,
 * and calibrates (colours, reference energy) on the first complete frame set.
 * Frame sets are the reference camera's frames with the other cameras'
 * frames taken within 10 ms of them.  The keypoints are those recorded live,
 * or with --detector those of another model run on every frame set (the
 * slower, more accurate config/models/ego_offline_detector.onnx, say). */
#include "base/mc_time.h"
#include "body/mc_model.h"
#include "geom/mc_rig.h"
#include "image/mc_image.h"
#include "image/mc_pixfmt.h"
#include "mc_detector.h"
#include "mc_install_paths.h" /* generated: MC_VERSION */
#include "take.h"
#include "track/mc_tracker.h"

#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define fail(code, ...) mc_fail_exit("mocap-track", code, __VA_ARGS__)
#define GROUP_TOLERANCE_NS 10000000ull

typedef struct {
	int iterations, resolution;
	const char *name;
	const char *detector; /* NULL: the keypoints recorded live */
	bool quiet;
	const char *take;
} options;

static void usage(FILE *f)
{
	fprintf(f, "usage: mocap-track [options] TAKE_DIR\n"
		   "Tracks a take recorded by mocapd again and writes TAKE_DIR/poses-NAME.mcr.\n"
		   "\n"
		   "  --iterations N   gradient iterations per frame set (default: twice the\n"
		   "                   tracker's default)\n"
		   "  --resolution N   working resolution per camera, N x N (default: the tracker's)\n"
		   "  --name NAME      the track's name (default retrack): poses-NAME.mcr\n"
		   "  --detector MODEL detect keypoints on every frame set with this ONNX model\n"
		   "                   (docs/DETECTOR.md) instead of using those recorded live\n"
		   "  --quiet          no progress bar\n"
		   "  -h, --help       this text\n"
		   "  -V, --version    the version\n");
}

static void parse_options(int argc, char **argv, options *o)
{
	static const struct option opts[] = {
		{"iterations", required_argument, NULL, 'i'}, {"resolution", required_argument, NULL, 'r'},
		{"name", required_argument, NULL, 'n'},       {"quiet", no_argument, NULL, 'q'},
		{"detector", required_argument, NULL, 'd'},
		{"help", no_argument, NULL, 'h'},             {"version", no_argument, NULL, 'V'},
		{NULL, 0, NULL, 0},
	};
	int c;
	while ((c = getopt_long(argc, argv, "hV", opts, NULL)) != -1) {
		char *end = NULL;
		long v;
		switch (c) {
		case 'i':
		case 'r':
			v = strtol(optarg, &end, 10);
			if (!*optarg || *end || v < 1 || v > (c == 'i' ? 10000 : 4096))
				fail(2, "--%s %s: expected %s", c == 'i' ? "iterations" : "resolution", optarg,
				     c == 'i' ? "1..10000" : "pixels, 1..4096");
			*(c == 'i' ? &o->iterations : &o->resolution) = (int)v;
			break;
		case 'n':
			o->name = optarg;
			if (!*optarg || strpbrk(optarg, "/ ") || strlen(optarg) > 64)
				fail(2, "--name %s: a short name without '/' or spaces", optarg);
			break;
		case 'd': o->detector = optarg; break;
		case 'q': o->quiet = true; break;
		case 'h': usage(stdout); exit(0);
		case 'V': printf("mocap-track %s\n", MC_VERSION); exit(0);
		default: usage(stderr); exit(2);
		}
	}
	if (optind + 1 != argc) {
		usage(stderr);
		exit(2);
	}
	o->take = argv[optind];
}

/* ---- the take's cameras, read in step ---- */

typedef struct {
	int rig_index;   /* the rig camera it is, -1: not tracked */
	take_reader r;
	bool have;       /* a frame is read and waiting */
	take_frame_meta m;
	const uint8_t *bytes;
	size_t n;
	uint8_t *rgb;
	int w, h;
} camera;

static bool advance(camera *c)
{
	c->have = take_reader_next_frame(&c->r, &c->m, &c->bytes, &c->n) == 1;
	return c->have;
}

static int decode(mc_image_conv *conv, camera *c, mc_err *err)
{
	free(c->rgb);
	c->rgb = NULL;
	if (c->m.pixfmt == MC_PIXFMT_MJPEG)
		return mc_image_decode(conv, c->bytes, c->n, "frame", &c->rgb, &c->w, &c->h, err);
	if (take_frame_check_raw(&c->m, c->n, err) < 0) /* before allocating from its size */
		return -1;
	c->w = (int)c->m.width;
	c->h = (int)c->m.height;
	size_t need = (size_t)c->w * c->h * 3;
	if (!(c->rgb = malloc(need)))
		return mc_err_set(err, "out of memory");
	mc_image_frame f = {.pixfmt = c->m.pixfmt, .width = c->m.width, .height = c->m.height, .stride = c->m.stride,
			    .data = c->bytes, .bytes = c->n};
	return mc_image_to_rgb24(conv, &f, c->rgb, need, err);
}

static int open_cameras(const char *take, const take_info *info, const mc_rig *rig, camera *cams, int *ref)
{
	mc_err err = {""};
	*ref = -1;
	for (int c = 0; c < info->ncams; c++) {
		char path[4300];
		cams[c].rig_index = -1;
		for (int k = 0; k < rig->ncams; k++)
			if (strcmp(rig->cams[k].name, info->rig_cams[c][0] ? info->rig_cams[c] : info->cams[c]) == 0)
				cams[c].rig_index = k;
		snprintf(path, sizeof(path), "%s/cam-%s.mcr", take, info->cams[c]);
		if (cams[c].rig_index < 0 || take_reader_open(&cams[c].r, path, &err) < 0) {
			cams[c].rig_index = -1;
			continue;
		}
		advance(&cams[c]);
		if (*ref < 0)
			*ref = c;
	}
	if (*ref < 0)
		fail(1, "%s: no camera of the take has frames and a rig camera (recorded with [record] frames = false?)",
		     take);
	return 0;
}

/* ---- the keypoints tracked with live ---- */

typedef struct {
	uint64_t capture_ns;
	int n;
	mc_keypoint *kp;
} keypoint_set;

/* Every KEYPOINTS record of poses.mcr, in order. */
static int load_keypoints(const char *take, keypoint_set **out)
{
	char path[4300];
	snprintf(path, sizeof(path), "%s/poses.mcr", take);
	take_reader r;
	mc_err err = {""};
	*out = NULL;
	if (take_reader_open(&r, path, &err) < 0)
		return 0;
	static take_keypoint kp[TAKE_MAX_KEYPOINTS];
	take_record_type type;
	const uint8_t *p;
	size_t size;
	int n = 0, cap = 0;
	while (take_reader_next(&r, &type, &p, &size, NULL) == 1) {
		uint64_t seq, t;
		int k;
		if (type != TAKE_KEYPOINTS || take_decode_keypoints(p, size, &seq, &t, kp, TAKE_MAX_KEYPOINTS, &k) < 0)
			continue;
		if (n == cap) {
			cap = cap ? 2 * cap : 256;
			keypoint_set *grown = realloc(*out, (size_t)cap * sizeof(**out));
			if (!grown)
				fail(1, "out of memory");
			*out = grown;
		}
		keypoint_set *s = &(*out)[n++];
		s->capture_ns = t;
		s->n = k;
		if (!(s->kp = malloc(sizeof(*s->kp) * (size_t)(k ? k : 1))))
			fail(1, "out of memory");
		for (int i = 0; i < k; i++)
			s->kp[i] = (mc_keypoint){kp[i].cam, kp[i].joint, kp[i].u, kp[i].v, kp[i].confidence};
	}
	take_reader_close(&r);
	return n;
}

/* The set captured at t (sets are in time order; *at moves forward). */
static const keypoint_set *keypoints_at(const keypoint_set *sets, int n, int *at, uint64_t t)
{
	while (*at < n && sets[*at].capture_ns < t)
		(*at)++;
	return *at < n && sets[*at].capture_ns == t ? &sets[*at] : NULL;
}

/* The --detector model, its joints mapped to the tracker's model's; exits
 * with the model's file named when it does not load or shares no joint. */
static mc_detector *load_detector(const options *o, const mc_tracker *t, int *map)
{
	mc_err err = {""};
	mc_detector *d = mc_detector_load(o->detector, &err);
	if (!d)
		fail(1, "--detector %s: %s", o->detector, err.msg);
	if (mc_detector_map_model(d, mc_tracker_model(t), map) == 0)
		fail(1, "--detector %s: none of its joints is a joint of the take's body model", o->detector);
	return d;
}

/* ---- the tracker ---- */

/* The live tracker's actor, as far as the take has it: bone scales from the
 * definition's offsets (the actor's) over the model's, and for a root fixed
 * to the rig its placement from the first skeleton's root joint.  True
 * when the first skeleton's pose vector can then be used as it is. */
static bool adopt_live_actor(mc_model *model, const take_poses *live)
{
	const take_pose *p = &live->poses[0];
	if (model->root_free || live->def.njoints != model->njoints || p->ndof != model->ndof)
		return false;
	for (int j = 0; j < model->njoints; j++) {
		double m = mc_v3_norm(model->joints[j].offset);
		const double *o = live->def.joints[j].offset;
		if (m > 1e-9)
			model->bone_scale[j] = sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]) / m;
	}
	const double *q = p->joints[0].orientation, *t = p->joints[0].position;
	model->rig_from_root.R = mc_quat_to_m3(mc_quat_normalize((mc_quat){q[0], q[1], q[2], q[3]}));
	model->rig_from_root.t = mc_v3(t[0], t[1], t[2]);
	return true;
}

static mc_tracker *start_tracker(const options *o, const take_poses *live, mc_rig *rig)
{
	mc_err err = {""};
	char path[4300];
	mc_model model;
	snprintf(path, sizeof(path), "%s/actor.json", o->take);
	if (access(path, R_OK) != 0)
		snprintf(path, sizeof(path), "%s/model.json", o->take);
	if (mc_model_load(path, &model, &err) < 0)
		fail(1, "%s", err.msg);
	if (rig->kind == MC_RIG_OUTSIDE_IN && !model.root_free && mc_model_make_root_free(&model, &err) < 0)
		fail(1, "%s", err.msg);
	bool adopted = adopt_live_actor(&model, live);
	mc_tracker_settings s;
	mc_tracker_settings_default(&s);
	s.iterations = o->iterations ? o->iterations : 2 * s.iterations;
	if (o->resolution)
		s.width = s.height = o->resolution;
	mc_tracker *t = mc_tracker_create(rig, &model, &s, &err);
	if (!t)
		fail(1, "%s", err.msg);
	/* From the first skeleton recorded live: its pose vector on the live
	 * actor, else (a free root) a fit to its joints. */
	const take_pose *p = &live->poses[0];
	if (adopted) {
		mc_tracker_set_pose(t, p->dofs);
		return t;
	}
	const char *names[TAKE_MAX_JOINTS];
	mc_vec3 pos[TAKE_MAX_JOINTS];
	/* Only the joints both records have: a crafted take's skeleton may
	 * claim more than its definition names (take_poses_load refuses it,
	 * this keeps the names and positions in step regardless). */
	int n = p->njoints < live->def.njoints ? p->njoints : live->def.njoints;
	for (int j = 0; j < n; j++) {
		names[j] = live->def.joints[j].name;
		pos[j] = mc_v3(p->joints[j].position[0], p->joints[j].position[1], p->joints[j].position[2]);
	}
	if (mc_tracker_init_from_joints(t, names, pos, n, &err) < 0)
		fail(1, "%s: the first recorded skeleton: %s", o->take, err.msg);
	return t;
}

/* A bar redrawn twice a second on a terminal; a line per tenth elsewhere
 * (a log or a pipe). */
static void progress(const options *o, int done, int total, uint64_t start_ns, bool last)
{
	static uint64_t next_ns;
	static int next_tenth = 1;
	uint64_t now = mc_now_ns();
	bool tty = isatty(2);
	if (o->quiet || (!last && (tty ? now < next_ns : !total || 10 * done < next_tenth * total)))
		return;
	next_ns = now + 500000000ull;
	next_tenth = total ? 10 * done / total + 1 : 1;
	double secs = (double)(now - start_ns) * 1e-9, rate = secs > 0 ? done / secs : 0;
	int filled = total ? 30 * done / total : 30;
	fprintf(stderr, "%s[%.*s%*s] %3d%% %d/%d frame sets, %.1f per s, ETA %.0f s %s", tty ? "\r" : "", filled,
		"##############################", 30 - filled, "", total ? 100 * done / total : 100, done, total, rate,
		rate > 0 ? (total - done) / rate : 0, tty && !last ? "" : "\n");
}

/* The frame set at t0: every camera's frame within GROUP_TOLERANCE_NS of
 * the reference camera's, decoded into views.  True when every camera
 * that has frames is in it. */
static bool gather_views(const options *o, const take_info *info, camera *cams, mc_image_conv *conv, uint64_t t0,
			 mc_frame_view *views)
{
	mc_err err = {""};
	bool complete = true;
	for (int c = 0; c < info->ncams; c++) {
		camera *cam = &cams[c];
		if (cam->rig_index < 0)
			continue;
		while (cam->have && cam->m.capture_ns + GROUP_TOLERANCE_NS < t0)
			advance(cam); /* frames with no partner in the reference camera */
		if (!cam->have || cam->m.capture_ns > t0 + GROUP_TOLERANCE_NS) {
			complete = false;
			continue; /* missing from this frame set */
		}
		if (decode(conv, cam, &err) < 0)
			fail(1, "%s: camera %s, frame %llu: %s", o->take, info->cams[c],
			     (unsigned long long)cam->m.sequence, err.msg);
		views[cam->rig_index] = (mc_frame_view){cam->w, cam->h, cam->w * 3, cam->rgb, cam->m.capture_ns};
	}
	return complete;
}

/* One tracked skeleton into the output track. */
static void write_pose(take_file *out, const take_poses *live, const mc_skeleton *sk, uint64_t seq, uint64_t t0,
		       uint64_t realtime_ns)
{
	static uint8_t buf[64 + 64 * TAKE_MAX_JOINTS];
	mc_err err = {""};
	take_pose p = {.seq = seq, .capture_ns = t0, .realtime_ns = realtime_ns, .state = (int)sk->state,
		       .def_id = live->def.id, .njoints = sk->njoints};
	for (int j = 0; j < sk->njoints; j++) {
		const mc_skeleton_joint *s = &sk->joints[j];
		p.joints[j] = (take_joint){{s->position.x, s->position.y, s->position.z},
					   {s->orientation.w, s->orientation.x, s->orientation.y, s->orientation.z},
					   s->confidence};
	}
	size_t n = take_encode_pose(&p, buf, sizeof(buf));
	if (take_file_append(out, TAKE_SKELETON, buf, n, NULL, 0, mc_now_ns(), &err) < 0)
		fail(1, "%s", err.msg);
}

int main(int argc, char **argv)
{
	options o = {.name = "retrack"};
	parse_options(argc, argv, &o);
	mc_err err = {""};
	take_info info;
	take_poses live;
	mc_rig rig;
	char path[4300];
	if (take_info_read(o.take, &info, &err) < 0 || take_poses_load(o.take, NULL, &live, &err) < 0)
		fail(1, "%s", err.msg);
	if (live.nposes == 0)
		fail(1, "%s: no skeleton recorded live to start from", o.take);
	snprintf(path, sizeof(path), "%s/rig.json", o.take);
	if (mc_rig_load(path, &rig, &err) < 0)
		fail(1, "%s", err.msg);
	static camera cams[TAKE_MAX_CAMERAS];
	int ref;
	open_cameras(o.take, &info, &rig, cams, &ref);
	int total = (int)info.frames[ref];
	mc_tracker *t = start_tracker(&o, &live, &rig);
	/* Before the output is created, so that a model that does not load
	 * leaves no poses-NAME.mcr behind. */
	int det_map[MC_DETECTOR_MAX_JOINTS];
	mc_detector *det = o.detector ? load_detector(&o, t, det_map) : NULL;

	/* The output: a definition from the live track, then the skeletons. */
	take_file out;
	snprintf(path, sizeof(path), "%s/poses-%s.mcr", o.take, o.name);
	static uint8_t buf[64 + 64 * TAKE_MAX_JOINTS];
	size_t n = take_encode_def(&live.def, buf, sizeof(buf));
	if (take_file_create(&out, path, &err) < 0 || take_file_append(&out, TAKE_DEF, buf, n, NULL, 0, mc_now_ns(), &err) < 0)
		fail(1, "%s", err.msg);
	mc_image_conv *conv = mc_image_conv_new(&err);
	if (!conv)
		fail(1, "%s", err.msg);
	keypoint_set *kps = NULL;
	int nkps = o.detector ? 0 : load_keypoints(o.take, &kps), kp_at = 0, kp_used = 0;
	static mc_keypoint detected[MC_MAX_CAMERAS * MC_DETECTOR_MAX_JOINTS];
	uint64_t start = mc_now_ns();
	int done = 0, states[MC_TRACK_INITIALISING + 1] = {0};
	bool calibrated = false;
	while (cams[ref].have) {
		mc_frame_view views[MC_MAX_CAMERAS] = {{0}};
		uint64_t t0 = cams[ref].m.capture_ns;
		bool complete = gather_views(&o, &info, cams, conv, t0, views);
		/* The tracker rates each frame set against the energy at its last
		 * calibration, and a tracker only set to a pose has none (every
		 * frame set was lost with the take's calibrated actor.json,
		 * issue 31): calibrate on the first frame set with every
		 * camera, at the first pose recorded live, as mocapd did at its
		 * start (calibrate_colors).  The colours are measured again there. */
		if (!calibrated && complete) {
			if (mc_tracker_calibrate_colors(t, views, rig.ncams, &err) < 0)
				fail(1, "%s: frame set %d: %s", o.take, done, err.msg);
			calibrated = true;
		}
		mc_skeleton sk;
		const keypoint_set *ks = keypoints_at(kps, nkps, &kp_at, t0);
		const mc_keypoint *kp = ks ? ks->kp : NULL;
		int nkp = ks ? ks->n : 0;
		if (det) {
			kp = detected;
			nkp = mc_detector_detect_views(det, views, rig.ncams, det_map, detected,
						       (int)(sizeof(detected) / sizeof(detected[0])), &err);
			if (nkp < 0)
				fail(1, "%s: frame set %d: --detector %s: %s", o.take, done, o.detector, err.msg);
		}
		kp_used += det ? nkp > 0 : ks != NULL;
		if (mc_tracker_track(t, views, rig.ncams, kp, nkp, &sk, &err) < 0)
			fail(1, "%s: frame set %d: %s", o.take, done, err.msg);
		write_pose(&out, &live, &sk, (uint64_t)done + 1, t0, cams[ref].m.realtime_ns);
		states[sk.state]++;
		done++;
		for (int c = 0; c < info.ncams; c++) /* the frames of this set are used */
			if (cams[c].rig_index >= 0 && cams[c].have && cams[c].m.capture_ns <= t0 + GROUP_TOLERANCE_NS)
				advance(&cams[c]);
		if (done < total)
			progress(&o, done, total, start, false);
	}
	progress(&o, done, done, start, true);
	if (take_file_sync(&out, &err) < 0)
		fail(1, "%s", err.msg);
	take_file_close(&out);
	double secs = (double)(mc_now_ns() - start) * 1e-9;
	printf("mocap-track: %d frame sets in %.1f s (%.1f per s) into %s: %d ok, %d uncertain, %d lost; "
	       "%d with %s\n",
	       done, secs, secs > 0 ? done / secs : 0.0, path, states[MC_TRACK_OK], states[MC_TRACK_UNCERTAIN],
	       states[MC_TRACK_LOST], kp_used, det ? "keypoints from --detector" : "the keypoints recorded live");
	mc_detector_free(det);
	for (int i = 0; i < nkps; i++)
		free(kps[i].kp);
	free(kps);
	for (int c = 0; c < info.ncams; c++) {
		take_reader_close(&cams[c].r);
		free(cams[c].rgb);
	}
	mc_image_conv_free(conv);
	mc_tracker_destroy(t);
	take_poses_free(&live);
	return 0;
}
