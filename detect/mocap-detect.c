/* mocap-detect: runs a 2D joint detector on the camera images of a running
 * mocapd and sends the keypoints back to it.
 *
 *     mocap-detect [--socket PATH] [--model MODEL.onnx] [--rate HZ] [--threads N] [--cameras A,B]
 *
 * This program is also the worked example for anyone who wants to plug in a
 * detector of their own (another network, another runtime, a marker
 * finder): everything it does goes through the public client library
 * (ipc/mocap.h) and the frame ring reader (core/ring/mc_ring.h), and only
 * load_model(), map_joints() and detect_view() below know about our
 * detector: replace those.  The steps:
 *
 *   1. connect to the daemon's socket (mocap_connect) as a privileged client:
 *      the daemon's user or group may map rings and send keypoints;
 *   2. ask for the skeleton (mocap_get_skeleton): keypoints name joints by
 *      their index in it, so map your detector's joint names to it;
 *   3. ask for the rig (mocap_get_rig): keypoints name cameras by their
 *      index in the rig's "cameras" array;
 *   4. ask for the camera rings (mocap_get_rings): one read-only memfd per
 *      camera; map each with mc_ring_map() (or mmap it yourself, layout in
 *      core/ring/mc_ring.h);
 *   5. loop, one thread per camera (so that one camera's frame never waits
 *      for another's detection): wait for a new frame (mc_ring_wait), copy
 *      the newest frame of the ring (mc_ring_read_latest),
 *      convert it to RGB (mc_image_to_rgb24: drivers deliver YUYV, MJPEG,
 *      Bayer, ...), detect, and send the keypoints with the frame's capture
 *      timestamp (mocap_send_keypoints).  The daemon matches each batch to
 *      the frame set of that capture time (within its grouping tolerance),
 *      so the batch must carry the timestamp of the image it came from, not
 *      the time it was sent.
 *
 * Keypoints are in the camera's native pixels (origin at the centre of the
 * top-left pixel) with a confidence in [0, 1]; send only joints the
 * detector found.  A detector slower than the cameras is fine: it skips to
 * the newest frame each time, and the tracker uses keypoints for the frame
 * sets they arrive in time for: before its last gradient iteration on that
 * frame set (it does not wait for them; docs/TRACKER.md, "Keypoints that
 * come during tracking").
 *
 * Exit status: 0 after SIGINT or SIGTERM, 1 on an error (no daemon, no
 * permission, a bad model, the daemon went away), 2 for a bad command line. */
#include "base/mc_time.h"
#include "image/mc_image.h"
#include "mc_detector.h"
#include "mocap.h"
#include "ring/mc_ring.h"

#include <errno.h>
#include <getopt.h>
#include <pthread.h>
#include <stdatomic.h>
#include <glob.h>
#include <jansson.h>
#include <signal.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define VERSION "0.1"

#include "mc_install_paths.h" /* generated: follows DATADIR at make install */
#define MOCAP_DETECT_MODEL_DIR MC_INSTALL_DATA_DIR "/models"

/* If no camera delivers a frame for this long, the rings are asked for
 * again (the daemon gives a camera a new ring when it reopens it). */
#define RING_STALE_NS 3000000000ull

/* One camera: its ring, and the thread that detects on it. */
typedef struct {
	char name[MOCAP_NAME_MAX];
	int rig_index;            /* camera index for KEYPOINTS */
	mc_ring *ring;
	mc_ring_cursor cursor;
	uint8_t *buf, *rgb;       /* a copy of the slot; the frame as RGB24 */
	size_t buf_cap, rgb_cap;
	pthread_t thread;
	bool running;
	_Atomic uint64_t last_frame_ns;
	/* statistics, written by the camera's thread, read after it ended */
	uint64_t views, keypoints, batches, skipped, errors;
	double ms_total, ms_max;
} camera;

/* SIGINT/SIGTERM, or a fatal error in a thread. */
static atomic_int stop;
/* Tells the camera threads to end so the rings can be reopened. */
static atomic_int restart;
static atomic_int exit_code;
/* Batches mocapd refused (reported by the next send). */
static atomic_ullong refused;

static void on_signal(int sig)
{
	(void)sig;
	atomic_store(&stop, 1);
}

static void usage(FILE *f)
{
	fprintf(f,
		"usage: mocap-detect [options]\n"
		"Runs the 2D joint detector on the camera images of a running mocapd and\n"
		"sends the keypoints back to it (docs/DETECT_RUNTIME.md).\n"
		"\n"
		"  --socket PATH    the daemon's socket (default: $MOCAP_SOCKET, else %s)\n"
		"  --model PATH     the detector, an ONNX file (default: the one *ego*.onnx, or\n"
		"                   *outside*.onnx when the daemon's rig is outside-in, in\n"
		"                   BINDIR/../share/mocapd/models, %s,\n"
		"                   or config/models)\n"
		"  --rate HZ        at most this many detections per camera per second\n"
		"                   (default 0: every frame, as fast as the detector goes)\n"
		"  --threads N      OpenCV threads for the network (default 1)\n"
		"  --cameras A,B    only these cameras (the daemon's camera names; default all)\n"
		"  --quiet          no progress lines, only errors and the statistics at exit\n"
		"  -h, --help       this text\n"
		"  -V, --version    the version\n",
		MOCAP_DEFAULT_SOCKET, MOCAP_DETECT_MODEL_DIR);
}

static void fail(const char *fmt, ...) __attribute__((format(printf, 1, 2), noreturn));
static void fail(const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	fputs("mocap-detect: ", stderr);
	vfprintf(stderr, fmt, ap);
	fputc('\n', stderr);
	va_end(ap);
	exit(1);
}

/* The shipped model for the daemon's rig: the one file matching `pattern`
 * (*ego*.onnx for head-mounted rigs, *outside*.onnx for outside-in ones)
 * in a models folder: next to the installed binary
 * (BINDIR/../share/mocapd/models, whatever PREFIX it was installed with),
 * the folder compiled in, config/models. */
static bool find_model(const char *pattern_name, char *path, size_t cap)
{
	char beside[4096] = "";
	ssize_t n = readlink("/proc/self/exe", beside, sizeof(beside) - 64);
	char *slash = n > 0 ? (beside[n] = 0, strrchr(beside, '/')) : NULL;
	if (slash)
		snprintf(slash, 64, "/../share/mocapd/models");
	else
		beside[0] = 0;
	const char *dirs[] = {beside, MOCAP_DETECT_MODEL_DIR, "config/models"};
	for (size_t i = 0; i < sizeof(dirs) / sizeof(dirs[0]); i++) {
		if (!dirs[i][0])
			continue;
		char pattern[4200];
		snprintf(pattern, sizeof(pattern), "%s/%s", dirs[i], pattern_name);
		glob_t g;
		if (glob(pattern, 0, NULL, &g) == 0 && g.gl_pathc > 0) {
			if (g.gl_pathc > 1)
				fprintf(stderr, "mocap-detect: %zu models match %s; using %s (choose with --model)\n",
					g.gl_pathc, pattern, g.gl_pathv[0]);
			snprintf(path, cap, "%s", g.gl_pathv[0]);
			globfree(&g);
			return true;
		}
		globfree(&g);
	}
	return false;
}

/* The rig JSON the daemon sends, parsed (fails the program otherwise). */
static json_t *daemon_rig(mocap_client *c)
{
	char *json = NULL;
	int ncams = 0;
	if (mocap_get_rig(c, &json, &ncams) < 0)
		fail("cannot get the rig from mocapd: %s", mocap_errmsg());
	json_error_t jerr;
	json_t *root = json_loads(json, 0, &jerr);
	free(json);
	if (!root)
		fail("the rig mocapd sent is not JSON: %s", jerr.text);
	return root;
}

/* Which shipped model suits the daemon's rig (docs/RIG_FORMAT.md "kind"). */
static const char *model_pattern_for_rig(mocap_client *c)
{
	json_t *root = daemon_rig(c);
	const char *kind = json_string_value(json_object_get(root, "kind"));
	bool outside = kind && !strcmp(kind, "outside-in");
	json_decref(root);
	return outside ? "*outside*.onnx" : "*ego*.onnx";
}

/* Connects as a client that may map camera rings and send keypoints. */
static mocap_client *connect_privileged(const char *socket_path)
{
	mocap_client *c = mocap_connect(socket_path, "mocap-detect");
	if (!c)
		fail("%s", mocap_errmsg());
	if (!mocap_is_privileged(c))
		fail("mocapd at %s does not let this user map camera rings or send keypoints: run as the daemon's "
		     "user or a member of its group",
		     socket_path ? socket_path : mocap_default_socket());
	return c;
}

/* Camera names in rig order, from the rig JSON the daemon sends. */
static int rig_cameras(mocap_client *c, char names[][MOCAP_NAME_MAX], int max)
{
	json_t *root = daemon_rig(c);
	json_t *cams = json_object_get(root, "cameras");
	if (!json_is_array(cams))
		fail("the rig mocapd sent has no \"cameras\" array");
	int n = 0;
	for (size_t i = 0; i < json_array_size(cams) && n < max; i++) {
		const char *s = json_string_value(json_object_get(json_array_get(cams, i), "name"));
		snprintf(names[n++], MOCAP_NAME_MAX, "%s", s ? s : "");
	}
	json_decref(root);
	return n;
}

static bool wanted(const char *list, const char *name)
{
	if (!list)
		return true;
	size_t n = strlen(name);
	for (const char *p = list; *p;) {
		const char *e = strchr(p, ',');
		size_t len = e ? (size_t)(e - p) : strlen(p);
		if (len == n && !strncmp(p, name, n))
			return true;
		p += len + (e ? 1 : 0);
	}
	return false;
}

static void close_rings(camera *cams, int ncams)
{
	for (int i = 0; i < ncams; i++) {
		mc_ring_close(cams[i].ring);
		cams[i].ring = NULL;
	}
}

/* Maps the daemon's rings (read-only) and gives each its rig camera index.
 * The daemon names a ring after its camera; the rig names its cameras the
 * same way in the usual configs (`[camera left]` with `rig_camera = left`).
 * Where no rig camera has the ring's name, ring i is taken to be rig camera
 * i.  Returns the number of cameras. */
static int open_rings(mocap_client *c, camera *cams, int old_n, const char *only, bool verbose)
{
	/* Statistics survive a reopening, matched by name; buffers do not. */
	camera old[MOCAP_MAX_RINGS];
	memcpy(old, cams, sizeof(camera) * (size_t)old_n);
	close_rings(cams, old_n);
	for (int k = 0; k < old_n; k++) {
		free(old[k].buf);
		free(old[k].rgb);
	}
	char rig[MOCAP_MAX_CAMERAS][MOCAP_NAME_MAX];
	int nrig = rig_cameras(c, rig, MOCAP_MAX_CAMERAS);
	mocap_ring rings[MOCAP_MAX_RINGS];
	int nr = mocap_get_rings(c, rings, MOCAP_MAX_RINGS);
	if (nr < 0)
		fail("cannot get the camera rings from mocapd: %s", mocap_errmsg());
	int n = 0;
	for (int i = 0; i < nr; i++) {
		mc_err err = {{0}};
		camera *cam = &cams[n];
		if (!wanted(only, rings[i].camera)) {
			close(rings[i].fd);
			continue;
		}
		memset(cam, 0, sizeof(*cam));
		for (int k = 0; k < old_n; k++)
			if (!strcmp(old[k].name, rings[i].camera)) {
				cam->views = old[k].views;
				cam->keypoints = old[k].keypoints;
				cam->batches = old[k].batches;
				cam->skipped = old[k].skipped;
				cam->errors = old[k].errors;
				cam->ms_total = old[k].ms_total;
				cam->ms_max = old[k].ms_max;
			}
		snprintf(cam->name, sizeof(cam->name), "%s", rings[i].camera);
		cam->ring = mc_ring_map(rings[i].fd, &err);
		close(rings[i].fd); /* the mapping stays */
		if (!cam->ring)
			fail("camera %s: cannot map its ring: %s", cam->name, err.msg);
		cam->rig_index = -1;
		for (int k = 0; k < nrig; k++)
			if (!strcmp(rig[k], cam->name))
				cam->rig_index = k;
		if (cam->rig_index < 0) {
			cam->rig_index = i < nrig ? i : -1;
			if (cam->rig_index < 0)
				fail("camera %s: no camera of that name in the rig, and ring %d has no rig camera %d",
				     cam->name, i, i);
			fprintf(stderr, "mocap-detect: camera %s: no rig camera of that name, taking rig camera %d (%s)\n",
				cam->name, i, rig[i]);
		}
		cam->cursor = mc_ring_cursor_now(cam->ring);
		cam->last_frame_ns = mc_now_ns();
		cam->buf_cap = mc_ring_slot_bytes(cam->ring);
		cam->buf = malloc(cam->buf_cap);
		if (!cam->buf)
			fail("out of memory");
		if (verbose)
			printf("mocap-detect: camera %s (rig camera %d)\n", cam->name, cam->rig_index);
		n++;
	}
	if (n == 0)
		fail(only ? "none of the cameras %s is offered by mocapd" : "mocapd offers no camera rings%s",
		     only ? only : "");
	return n;
}

/* ---- The detector.  Replace this part to plug in your own: in, one RGB
 * image; out, keypoints in the daemon's skeleton joint indices. */

/* Detector joint -> skeleton joint (-1: none), shared by the camera
 * threads; map_version changes when the main thread maps again. */
static pthread_mutex_t map_lock = PTHREAD_MUTEX_INITIALIZER;
static int joint_map[MC_DETECTOR_MAX_JOINTS];
static atomic_int map_version;
/* A camera thread saw a refusal: the main thread maps again. */
static atomic_int remap_wanted;

/* Maps the model's joints to the daemon's skeleton (again after a reload
 * may have changed it).  d: any detector of the model. */
static void map_joints(const mc_detector *d, mocap_client *c, bool verbose)
{
	/* The daemon's skeleton: retried for a while, it is there once the
	 * daemon loaded its model. */
	mocap_skeleton_def *def = calloc(1, sizeof(*def));
	int rc = MOCAP_E_UNAVAILABLE;
	for (int i = 0; def && i < 50 && !atomic_load(&stop) && (rc = mocap_get_skeleton(c, def)) == MOCAP_E_UNAVAILABLE;
	     i++)
		usleep(100000);
	if (!def || rc < 0)
		fail("cannot get the skeleton from mocapd: %s", def ? mocap_errmsg() : "out of memory");
	const char *names[MOCAP_MAX_JOINTS];
	for (int j = 0; j < def->njoints; j++)
		names[j] = def->joints[j].name;
	const char *model = mc_detector_path(d);
	int map[MC_DETECTOR_MAX_JOINTS];
	int found = mc_detector_map_names(d, names, def->njoints, map);
	if (found == 0)
		fail("%s: none of its %d joints is in the daemon's skeleton", model, mc_detector_njoints(d));
	if (verbose) {
		printf("mocap-detect: %s: %d of its %d joints are in the daemon's skeleton", model, found,
		       mc_detector_njoints(d));
		const char *sep = " (not: ";
		for (int j = 0; j < mc_detector_njoints(d); j++)
			if (map[j] < 0) {
				printf("%s%s", sep, mc_detector_joint_name(d, j));
				sep = ", ";
			}
		printf("%s\n", strcmp(sep, ", ") ? "" : ")");
	}
	free(def);
	pthread_mutex_lock(&map_lock);
	memcpy(joint_map, map, sizeof(map));
	pthread_mutex_unlock(&map_lock);
	atomic_fetch_add(&map_version, 1);
}

/* One camera thread's detector. */
typedef struct {
	mc_detector *det;
	int map[MC_DETECTOR_MAX_JOINTS];
	int map_version;
} detector;

static mc_detector *load_model(const char *model)
{
	mc_err err = {{0}};
	mc_detector *d = mc_detector_load(model, &err);
	if (!d)
		fail("%s", err.msg);
	return d;
}

/* Returns the keypoint count, or -1 with err. */
static int detect_view(detector *d, const uint8_t *rgb, int width, int height, mocap_keypoint *kp, int max,
		       mc_err *err)
{
	if (d->map_version != atomic_load(&map_version)) {
		pthread_mutex_lock(&map_lock);
		memcpy(d->map, joint_map, sizeof(d->map));
		d->map_version = atomic_load(&map_version);
		pthread_mutex_unlock(&map_lock);
	}
	mc_detection det[MC_DETECTOR_MAX_JOINTS];
	int nd = mc_detector_detect(d->det, rgb, width, height, 0, det, MC_DETECTOR_MAX_JOINTS, err);
	if (nd < 0)
		return -1;
	int n = 0;
	for (int i = 0; i < nd && n < max; i++) {
		int joint = d->map[det[i].joint];
		if (joint >= 0)
			kp[n++] = (mocap_keypoint){.joint = joint, .u = det[i].u, .v = det[i].v, .confidence = det[i].confidence};
	}
	return n;
}

/* ---- The camera threads. */

/* The newest frame of a camera, as RGB in cam->rgb.  1: a new frame (meta
 * filled), 0: none, -1: error (printed). */
static int newest_rgb(camera *cam, mc_image_conv *conv, mc_ring_meta *meta)
{
	mc_err err = {{0}};
	uint64_t before = cam->cursor.missed;
	int rc = mc_ring_read_latest(cam->ring, &cam->cursor, cam->buf, cam->buf_cap, meta, &err);
	if (rc == MC_RING_NONE)
		return 0;
	if (rc != MC_RING_FRAME) {
		fprintf(stderr, "mocap-detect: camera %s: %s\n", cam->name, err.msg);
		return -1;
	}
	if (cam->views > 0)
		cam->skipped += cam->cursor.missed - before;
	size_t need = (size_t)meta->width * meta->height * 3;
	if (need > cam->rgb_cap) {
		free(cam->rgb);
		cam->rgb = malloc(need);
		cam->rgb_cap = cam->rgb ? need : 0;
		if (!cam->rgb)
			fail("out of memory");
	}
	mc_image_frame f = {.pixfmt = meta->pixfmt,
			    .width = meta->width,
			    .height = meta->height,
			    .stride = meta->stride,
			    .data = cam->buf,
			    .bytes = (size_t)meta->bytesused};
	if (mc_image_to_rgb24(conv, &f, cam->rgb, cam->rgb_cap, &err) < 0) {
		fprintf(stderr, "mocap-detect: camera %s: %s\n", cam->name, err.msg);
		return -1;
	}
	return 1;
}

static bool ending(void)
{
	return atomic_load(&stop) || atomic_load(&restart);
}

/* Sleeps until t_ns, or until told to end. */
static void sleep_until(uint64_t t_ns)
{
	while (!ending()) {
		uint64_t now = mc_now_ns();
		if (now >= t_ns)
			return;
		uint64_t d = t_ns - now > 50000000ull ? 50000000ull : t_ns - now;
		struct timespec ts = mc_ns_timespec(d);
		nanosleep(&ts, NULL);
	}
}

typedef struct {
	camera *cam;
	mocap_client *client;
	const char *model;
	uint64_t period_ns; /* --rate; 0: every frame */
} worker_args;

/* Waits for each new frame of one camera, detects, sends. */
static void *camera_thread(void *arg)
{
	worker_args *w = arg;
	camera *cam = w->cam;
	detector det = {.det = load_model(w->model), .map_version = -1};
	mc_err err = {{0}};
	mc_image_conv *conv = mc_image_conv_new(&err);
	if (!conv)
		fail("%s", err.msg);
	while (!ending()) {
		uint64_t start_ns = mc_now_ns();
		mc_ring_meta meta;
		int rc = newest_rgb(cam, conv, &meta);
		if (rc < 0)
			cam->errors++;
		if (rc <= 0) {
			/* Nothing new: wait for the next commit (a futex in the
			 * ring: we wake as soon as the driver commits). */
			if (mc_ring_wait(cam->ring, &cam->cursor, 100, &err) < 0)
				sleep_until(mc_now_ns() + 10000000ull);
			continue;
		}
		atomic_store(&cam->last_frame_ns, mc_now_ns());
		mocap_keypoint kp[MOCAP_MAX_KEYPOINTS];
		uint64_t t0 = mc_now_ns();
		int n = detect_view(&det, cam->rgb, (int)meta.width, (int)meta.height, kp, MOCAP_MAX_KEYPOINTS, &err);
		double ms = mc_ms_since(t0);
		if (n < 0) {
			fprintf(stderr, "mocap-detect: camera %s: %s\n", cam->name, err.msg);
			cam->errors++;
			continue;
		}
		cam->views++;
		cam->ms_total += ms;
		if (ms > cam->ms_max)
			cam->ms_max = ms;
		if (n > 0) {
			/* The capture time of the image, not now. */
			rc = mocap_send_keypoints(w->client, meta.timestamp_ns, cam->rig_index, kp, n);
			if (rc == MOCAP_E_REFUSED || rc == MOCAP_E_PERMISSION) {
				/* An earlier batch was refused (this one was sent):
				 * maybe a reload changed the skeleton; map again. */
				if (atomic_fetch_add(&refused, 1) < 5)
					fprintf(stderr, "mocap-detect: mocapd refused keypoints: %s\n", mocap_errmsg());
				atomic_store(&remap_wanted, 1);
				rc = 0;
			}
			if (rc < 0) {
				fprintf(stderr, "mocap-detect: cannot send keypoints: %s\n", mocap_errmsg());
				atomic_store(&exit_code, 1);
				atomic_store(&stop, 1);
				break;
			}
			cam->batches++;
			cam->keypoints += (uint64_t)n;
		}
		if (w->period_ns)
			sleep_until(start_ns + w->period_ns);
	}
	mc_image_conv_free(conv);
	mc_detector_free(det.det);
	return NULL;
}

/* Starts one thread per camera. */
static void start_threads(camera *cams, int ncams, worker_args *args, mocap_client *c, const char *model,
			  uint64_t period_ns)
{
	atomic_store(&restart, 0);
	for (int i = 0; i < ncams; i++) {
		args[i] = (worker_args){.cam = &cams[i], .client = c, .model = model, .period_ns = period_ns};
		int rc = pthread_create(&cams[i].thread, NULL, camera_thread, &args[i]);
		if (rc)
			fail("cannot start a thread: %s", strerror(rc));
		cams[i].running = true;
	}
}

static void join_threads(camera *cams, int ncams)
{
	atomic_store(&restart, 1);
	for (int i = 0; i < ncams; i++)
		if (cams[i].running) {
			pthread_join(cams[i].thread, NULL);
			cams[i].running = false;
		}
}

int main(int argc, char **argv)
{
	const char *socket_path = NULL, *model = NULL, *only = NULL;
	double rate = 0;
	int threads = 1;
	bool verbose = true;
	enum { OPT_SOCKET = 256, OPT_MODEL, OPT_RATE, OPT_THREADS, OPT_CAMERAS, OPT_QUIET };
	static const struct option opts[] = {
		{"socket", required_argument, NULL, OPT_SOCKET},   {"model", required_argument, NULL, OPT_MODEL},
		{"rate", required_argument, NULL, OPT_RATE},       {"threads", required_argument, NULL, OPT_THREADS},
		{"cameras", required_argument, NULL, OPT_CAMERAS}, {"quiet", no_argument, NULL, OPT_QUIET},
		{"help", no_argument, NULL, 'h'},                  {"version", no_argument, NULL, 'V'},
		{NULL, 0, NULL, 0},
	};
	int o;
	while ((o = getopt_long(argc, argv, "hV", opts, NULL)) != -1) {
		char *end = NULL;
		switch (o) {
		case OPT_SOCKET: socket_path = optarg; break;
		case OPT_MODEL: model = optarg; break;
		case OPT_CAMERAS: only = optarg; break;
		case OPT_QUIET: verbose = false; break;
		case OPT_RATE:
			rate = strtod(optarg, &end);
			if (!*optarg || *end || !(rate >= 0 && rate <= 1000)) {
				fprintf(stderr, "mocap-detect: --rate %s: expected detections per second, 0..1000 (0: every frame)\n",
					optarg);
				return 2;
			}
			break;
		case OPT_THREADS: {
			long t = strtol(optarg, &end, 10);
			if (!*optarg || *end || t < 1 || t > 64) {
				fprintf(stderr, "mocap-detect: --threads %s: expected a thread count, 1..64\n", optarg);
				return 2;
			}
			threads = (int)t;
			break;
		}
		case 'h': usage(stdout); return 0;
		case 'V': printf("mocap-detect %s (libmocap %s)\n", VERSION, MOCAP_LIB_VERSION); return 0;
		default: usage(stderr); return 2;
		}
	}
	if (optind < argc) {
		fprintf(stderr, "mocap-detect: unexpected argument '%s'\n", argv[optind]);
		usage(stderr);
		return 2;
	}
	char found_model[4096];
	mocap_client *c = NULL;
	if (!model) {
		/* the model suits the rig: ask the daemon which kind it has */
		c = connect_privileged(socket_path);
		const char *pattern = model_pattern_for_rig(c);
		if (!find_model(pattern, found_model, sizeof(found_model)))
			fail("no detector model: no %s beside the binary (../share/mocapd/models), in %s or in "
			     "config/models; give one with --model",
			     pattern, MOCAP_DETECT_MODEL_DIR);
		model = found_model;
	}
	setvbuf(stdout, NULL, _IOLBF, 0);
	struct sigaction sa = {.sa_handler = on_signal};
	sigemptyset(&sa.sa_mask);
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);
	signal(SIGPIPE, SIG_IGN);

	/* The model first: a bad one is reported before anything else. */
	mc_detector *names = load_model(model);
	mc_detector_set_threads(threads);
	/* 1. Connect (privileged: rings and keypoints need it). */
	if (!c)
		c = connect_privileged(socket_path);
	/* 2. The model's joints in the daemon's skeleton. */
	map_joints(names, c, verbose);
	/* 3, 4. The rig and the rings. */
	static camera cams[MOCAP_MAX_RINGS];
	worker_args args[MOCAP_MAX_RINGS];
	int ncams = open_rings(c, cams, 0, only, verbose);

	/* 5. A thread per camera detects and sends; this one watches. */
	const uint64_t period_ns = rate > 0 ? (uint64_t)(1e9 / rate) : 0;
	uint64_t start_ns = mc_now_ns();
	start_threads(cams, ncams, args, c, model, period_ns);
	while (!atomic_load(&stop)) {
		struct timespec ts = {.tv_nsec = 100000000L};
		nanosleep(&ts, NULL);
		if (atomic_exchange(&remap_wanted, 0))
			map_joints(names, c, false);
		/* Every camera silent for long: the daemon may have reopened
		 * them with new rings (or stopped: then the ping fails). */
		bool stale = true;
		uint64_t now = mc_now_ns();
		for (int i = 0; i < ncams; i++)
			stale = stale && now - atomic_load(&cams[i].last_frame_ns) > RING_STALE_NS;
		if (!stale || atomic_load(&stop))
			continue;
		if (mocap_ping(c, NULL) < 0) {
			fprintf(stderr, "mocap-detect: lost mocapd: %s\n", mocap_errmsg());
			atomic_store(&exit_code, 1);
			break;
		}
		join_threads(cams, ncams);
		ncams = open_rings(c, cams, ncams, only, false);
		map_joints(names, c, false);
		start_threads(cams, ncams, args, c, model, period_ns);
	}
	atomic_store(&stop, 1);
	join_threads(cams, ncams);

	/* Statistics. */
	double secs = mc_ms_since(start_ns) / 1e3;
	printf("mocap-detect: %.1f s, model %s\n", secs, model);
	for (int i = 0; i < ncams; i++) {
		const camera *cam = &cams[i];
		printf("mocap-detect: camera %s: %llu views (%.1f per s), %.2f ms per view (max %.2f), %llu keypoints "
		       "in %llu batches, %llu frames skipped, %llu errors\n",
		       cam->name, (unsigned long long)cam->views, secs > 0 ? (double)cam->views / secs : 0.0,
		       cam->views ? cam->ms_total / (double)cam->views : 0.0, cam->ms_max,
		       (unsigned long long)cam->keypoints, (unsigned long long)cam->batches,
		       (unsigned long long)cam->skipped, (unsigned long long)cam->errors);
	}
	printf("mocap-detect: %llu refusals from mocapd\n", (unsigned long long)atomic_load(&refused));
	close_rings(cams, ncams);
	for (int i = 0; i < ncams; i++) {
		free(cams[i].buf);
		free(cams[i].rgb);
	}
	mc_detector_free(names);
	mocap_close(c);
	return atomic_load(&exit_code);
}
