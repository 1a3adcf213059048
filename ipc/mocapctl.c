/* mocapctl: command-line client of mocapd (status, watch, rig, skeleton,
 * reload, record, actor save).  Built on libmocap; see `mocapctl --help`. */
#include "mocap.h"
#include "take.h"

#include <ctype.h>
#include <dirent.h>
#include <errno.h>
#include <signal.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Exit codes, also listed in --help and docs/PROTOCOL.md. */
enum {
	EXIT_OK = 0,
	EXIT_FAILED = 1,      /* the daemon refused or a command failed */
	EXIT_USAGE = 2,
	EXIT_NOT_RUNNING = 3, /* cannot connect: no daemon at the path */
	EXIT_PERMISSION = 4,  /* socket or request not allowed for this user */
	EXIT_VERSION = 5,     /* protocol version mismatch */
	EXIT_LOST = 6,        /* connection lost or protocol error */
	EXIT_RESTART = 7,     /* reload: done, but some changes need a restart */
};

static const char usage[] =
	"usage: mocapctl [--socket PATH] COMMAND [OPTIONS]\n"
	"\n"
	"commands:\n"
	"  status                 cameras, frame rates, drops, tracking time, tracker state, detector\n"
	"      --json             as one JSON object (fields as in libmocap's mocap_daemon_status)\n"
	"  watch                  print skeletons as they arrive\n"
	"      --json             one JSON object per frame and line\n"
	"      --count N          stop after N frames\n"
	"      --all              every frame (recorder mode) instead of only the newest\n"
	"      --world            world frame (needs a head pose from a VR runtime)\n"
	"  rig                    print the rig in use (JSON)\n"
	"  skeleton               print the joints: names, parents, rest offsets\n"
	"  reload                 reload configuration, rig and model (daemon's user or group)\n"
	"  record start [--name NAME | PATH]\n"
	"                         start recording a take: NAME in the daemon's [record] directory\n"
	"                         (default: take-YYYYmmdd-HHMMSS) or an absolute PATH (daemon's user\n"
	"                         or group)\n"
	"  record stop            stop recording; prints how the take ended\n"
	"  record status          the take being recorded, or how the last one ended\n"
	"  record list            the takes, one per line: directory, state, duration, poses\n"
	"  actor save NAME        save the calibrated actor (size, colours) as [tracker] actor_dir/NAME.json,\n"
	"                         for [tracker] actor at the next start (daemon's user or group)\n"
	"  steer TARGET...        steer a [source] graph walk: class NAME, frame N,\n"
	"                         direction DEG [speed M/S], speed M/S, or none (daemon's user or\n"
	"                         group)\n"
	"  ping                   round-trip time to the daemon\n"
	"  --version, -V          this program's version and the daemon's, if one answers\n"
	"\n"
	"The socket is --socket PATH, else $MOCAP_SOCKET, else " MOCAP_DEFAULT_SOCKET ".\n"
	"PATH may be tcp://HOST:PORT for a daemon on another machine ([network] in its\n"
	"config); the token is then $MOCAP_TOKEN or the first line of $MOCAP_TOKEN_FILE.\n"
	"Exit status: 0 ok, 1 refused or failed, 2 usage, 3 daemon not running,\n"
	"4 permission denied, 5 protocol version mismatch, 6 connection lost,\n"
	"7 reloaded but some changes need a restart (the reply names them).\n";

static volatile sig_atomic_t interrupted;
static void on_signal(int sig) { (void)sig; interrupted = 1; }

static int exit_code_for(int err)
{
	switch (err) {
	case MOCAP_E_NOT_RUNNING: return EXIT_NOT_RUNNING;
	case MOCAP_E_ACCESS:
	case MOCAP_E_PERMISSION: return EXIT_PERMISSION;
	case MOCAP_E_VERSION: return EXIT_VERSION;
	case MOCAP_E_DISCONNECTED:
	case MOCAP_E_PROTOCOL:
	case MOCAP_E_TIMEOUT: return EXIT_LOST;
	}
	return EXIT_FAILED;
}

static int fail(const char *what)
{
	int code = mocap_errcode();
	fprintf(stderr, "mocapctl: %s%s%s\n", what ? what : "", what ? ": " : "", mocap_errmsg());
	return exit_code_for(code);
}

static const char *cam_state_name(int s)
{
	static const char *names[] = {"ok", "stalled", "error", "off", "failed"};
	return s >= 0 && s < 5 ? names[s] : "unknown";
}

static void print_duration(double s)
{
	if (s >= 3600)
		printf("%dh%02dm", (int)(s / 3600), (int)(s / 60) % 60);
	else if (s >= 60)
		printf("%dm%02ds", (int)(s / 60), (int)s % 60);
	else
		printf("%.1fs", s);
}

static void json_string(const char *s)
{
	putchar('"');
	for (; *s; s++) {
		unsigned char ch = (unsigned char)*s;
		if (ch == '"' || ch == '\\')
			printf("\\%c", ch);
		else if (ch < 0x20)
			printf("\\u%04x", ch);
		else
			putchar(ch);
	}
	putchar('"');
}

/* "detector:   running, 59.8 views/s, 1.05 ms per view (last 1.01, max 1.90), ..." */
static void print_detector(const mocap_detector_status *d)
{
	printf("detector:   ");
	switch (d->state) {
	case MOCAP_DETECTOR_OFF:
		printf("off\n");
		return;
	case MOCAP_DETECTOR_FAILED:
		printf("failed: %s\n", d->message);
		return;
	case MOCAP_DETECTOR_RUNNING:
		printf("running, %.1f views/s, %.2f ms per view (last %.2f, max %.2f)\n", d->rate, d->ms_mean, d->ms_last,
		       d->ms_max);
		printf("            %llu views detected, %llu skipped; %llu tracked with its keypoints (%.1f/s); model %s\n",
		       (unsigned long long)d->views, (unsigned long long)d->skipped, (unsigned long long)d->used,
		       d->used_rate, d->model);
		return;
	default:
		printf("unknown (the daemon speaks protocol version 1)\n");
	}
}

static const char *const latency_stage_names[MOCAP_LAT_NSTAGES] = {"ready",	"wait",	   "decode",
								    "track",	"publish", "total"};

/* "latency:    capture to publish 41.2 ms p50, 63.0 p99, 80.1 max over 900 frame sets"
 * and a line per stage. */
static void print_latency(const mocap_latency_status *l)
{
	static const char *const what[MOCAP_LAT_NSTAGES] = {
		"capture -> set complete", "-> tracking starts", "-> views decoded", "-> tracking ends", "-> published",
		""};
	if (!l->known) {
		printf("latency:    unknown (the daemon speaks protocol version 2 or older)\n");
		return;
	}
	printf("latency:    capture to publish %.1f ms p50, %.1f p99, %.1f max over the last %u frame sets\n",
	       l->stage[MOCAP_LAT_TOTAL].p50, l->stage[MOCAP_LAT_TOTAL].p99, l->stage[MOCAP_LAT_TOTAL].max, l->window);
	for (int s = 0; s < MOCAP_LAT_TOTAL; s++)
		printf("  %-8s %-24s %7.1f ms p50 %7.1f p99 %7.1f max\n", latency_stage_names[s], what[s], l->stage[s].p50,
		       l->stage[s].p99, l->stage[s].max);
	printf("            frame sets skipped: %llu behind (a newer one was due), %llu stale (over max_frame_age_ms); "
	       "%llu without every camera\n",
	       (unsigned long long)l->skipped_behind, (unsigned long long)l->skipped_stale,
	       (unsigned long long)l->incomplete);
}

static void print_latency_json(const mocap_latency_status *l)
{
	printf(", \"latency\": {\"known\": %s, \"window\": %u", l->known ? "true" : "false", l->window);
	for (int s = 0; s < MOCAP_LAT_NSTAGES; s++)
		printf(", \"%s\": {\"p50_ms\": %.3f, \"p99_ms\": %.3f, \"max_ms\": %.3f}", latency_stage_names[s],
		       l->stage[s].p50, l->stage[s].p99, l->stage[s].max);
	printf(", \"skipped_behind\": %llu, \"skipped_stale\": %llu, \"incomplete\": %llu}",
	       (unsigned long long)l->skipped_behind, (unsigned long long)l->skipped_stale,
	       (unsigned long long)l->incomplete);
}

/* `status --json`: the same figures as one JSON object, for scripts. */
static void print_status_json(const mocap_daemon_status *st, const char *path)
{
	printf("{\"socket\": ");
	json_string(path);
	printf(", \"tracker_state\": ");
	json_string(mocap_track_state_name(st->tracker_state));
	printf(", \"device\": ");
	json_string(st->device);
	printf(", \"frames_published\": %llu, \"publish_fps\": %.3f, \"frames_skipped\": %llu, "
	       "\"track_ms_mean\": %.3f, \"track_ms_max\": %.3f, \"clients\": %d, \"client_drops\": %llu, "
	       "\"recording\": %s, \"uptime_s\": %.3f",
	       (unsigned long long)st->frames_published, st->publish_fps, (unsigned long long)st->frames_dropped,
	       st->track_ms_mean, st->track_ms_max, st->clients, (unsigned long long)st->client_drops,
	       st->recording ? "true" : "false", (double)st->uptime_ns * 1e-9);
	const mocap_detector_status *d = &st->detector;
	static const char *const dstate[] = {"off", "running", "failed", "unknown"};
	printf(", \"detector\": {\"state\": \"%s\", \"views_per_s\": %.3f, \"used_per_s\": %.3f, \"ms_mean\": %.3f, "
	       "\"ms_last\": %.3f, \"ms_max\": %.3f, \"views\": %llu, \"skipped\": %llu, \"used\": %llu, \"model\": ",
	       (unsigned)d->state < 4 ? dstate[d->state] : "unknown", d->rate, d->used_rate, d->ms_mean, d->ms_last,
	       d->ms_max, (unsigned long long)d->views, (unsigned long long)d->skipped, (unsigned long long)d->used);
	json_string(d->model);
	printf(", \"message\": ");
	json_string(d->message);
	printf("}");
	print_latency_json(&st->latency);
	printf(", \"cameras\": [");
	for (int i = 0; i < st->ncams; i++) {
		const mocap_camera_status *cs = &st->cams[i];
		printf("%s{\"name\": ", i ? ", " : "");
		json_string(cs->name);
		printf(", \"state\": \"%s\", \"width\": %d, \"height\": %d, \"fps\": %.3f, \"frames\": %llu, "
		       "\"drops\": %llu}",
		       cam_state_name(cs->state), cs->width, cs->height, cs->fps, (unsigned long long)cs->frames,
		       (unsigned long long)cs->drops);
	}
	printf("]}\n");
}

static int cmd_status(mocap_client *c, const char *path, bool json)
{
	mocap_daemon_status st;
	int rc = mocap_get_status(c, &st);
	if (rc)
		return fail("status");
	if (json) {
		print_status_json(&st, path);
		return EXIT_OK;
	}
	printf("mocapd at %s\n", path);
	printf("tracker:    %s", mocap_track_state_name(st.tracker_state));
	if (st.device[0])
		printf("  (device: %s)", st.device);
	printf("\npublished:  %llu skeletons, %.1f fps; frame sets skipped by the tracker: %llu\n",
	       (unsigned long long)st.frames_published, st.publish_fps, (unsigned long long)st.frames_dropped);
	printf("tracking:   %.2f ms mean, %.2f ms max per frame\n", st.track_ms_mean, st.track_ms_max);
	print_detector(&st.detector);
	print_latency(&st.latency);
	printf("clients:    %d connected; frames dropped for slow clients: %llu\n", st.clients,
	       (unsigned long long)st.client_drops);
	printf("recording:  %s\n", st.recording ? "yes" : "no");
	printf("uptime:     ");
	print_duration((double)st.uptime_ns * 1e-9);
	printf("\ncameras:    %d\n", st.ncams);
	for (int i = 0; i < st.ncams; i++) {
		const mocap_camera_status *cs = &st.cams[i];
		printf("  %-16s %-8s %5dx%-5d %6.1f fps  frames %llu  drops %llu\n", cs->name, cam_state_name(cs->state),
		       cs->width, cs->height, cs->fps, (unsigned long long)cs->frames, (unsigned long long)cs->drops);
	}
	return EXIT_OK;
}

static const char *joint_name(const mocap_skeleton_def *s, const mocap_skeleton_frame *f, int j, char *buf, size_t n)
{
	if (s && s->id == f->skeleton_id && j < s->njoints)
		return s->joints[j].name;
	snprintf(buf, n, "joint%d", j);
	return buf;
}

static void print_frame_json(const mocap_skeleton_frame *f, const mocap_skeleton_def *s)
{
	printf("{\"seq\":%llu,\"capture_ns\":%llu,\"publish_ns\":%llu,\"receive_ns\":%llu,\"missed\":%llu,"
	       "\"state\":\"%s\",\"space\":\"%s\",\"skeleton_id\":%u,\"joints\":{",
	       (unsigned long long)f->seq, (unsigned long long)f->capture_ns, (unsigned long long)f->publish_ns,
	       (unsigned long long)f->receive_ns, (unsigned long long)f->missed, mocap_track_state_name(f->state),
	       f->space == MOCAP_SPACE_WORLD ? "world" : "rig", f->skeleton_id);
	for (int j = 0; j < f->njoints; j++) {
		char buf[32];
		const mocap_joint *jt = &f->joints[j];
		if (j)
			putchar(',');
		json_string(joint_name(s, f, j, buf, sizeof(buf)));
		printf(":{\"position\":[%.6f,%.6f,%.6f],\"orientation\":[%.6f,%.6f,%.6f,%.6f],\"confidence\":%.3f}",
		       jt->position[0], jt->position[1], jt->position[2], jt->orientation[0], jt->orientation[1],
		       jt->orientation[2], jt->orientation[3], (double)jt->confidence);
	}
	printf("}}\n");
}

static void print_frame_text(const mocap_skeleton_frame *f, const mocap_skeleton_def *s)
{
	if (f->missed)
		printf("(%llu frames missed)\n", (unsigned long long)f->missed);
	printf("frame %llu  state %s  space %s  latency %.3f ms (publish to receive), %.1f ms (capture to receive)\n",
	       (unsigned long long)f->seq, mocap_track_state_name(f->state),
	       f->space == MOCAP_SPACE_WORLD ? "world" : "rig", (double)(f->receive_ns - f->publish_ns) * 1e-6,
	       (double)(f->receive_ns - f->capture_ns) * 1e-6);
	for (int j = 0; j < f->njoints; j++) {
		char buf[32];
		const mocap_joint *jt = &f->joints[j];
		printf("  %-16s %8.4f %8.4f %8.4f  conf %.2f\n", joint_name(s, f, j, buf, sizeof(buf)), jt->position[0],
		       jt->position[1], jt->position[2], (double)jt->confidence);
	}
}

static int cmd_watch(mocap_client *c, bool json, long count, bool all, bool world)
{
	mocap_skeleton_def *skel = calloc(1, sizeof(*skel));
	mocap_skeleton_frame *f = malloc(sizeof(*f));
	if (!skel || !f) {
		free(skel);
		free(f);
		fprintf(stderr, "mocapctl: out of memory\n");
		return EXIT_FAILED;
	}
	int rc = EXIT_OK;
	bool have_skel = mocap_get_skeleton(c, skel) == 0;
	if (mocap_subscribe(c, all ? MOCAP_ALL : MOCAP_LATEST, world ? MOCAP_SPACE_WORLD : MOCAP_SPACE_RIG, 0)) {
		rc = fail("subscribe");
		goto out;
	}
	for (long n = 0; (count <= 0 || n < count) && !interrupted;) {
		int r = mocap_read_frame(c, f, 500);
		if (r < 0) {
			rc = fail("watch");
			goto out;
		}
		if (r == 0)
			continue;
		/* A new definition (after a reload): fetch the names again. */
		if (!have_skel || skel->id != f->skeleton_id)
			have_skel = mocap_get_skeleton(c, skel) == 0;
		if (json)
			print_frame_json(f, have_skel ? skel : NULL);
		else
			print_frame_text(f, have_skel ? skel : NULL);
		fflush(stdout);
		n++;
	}
out:
	free(skel);
	free(f);
	return rc;
}

static int cmd_rig(mocap_client *c)
{
	char *json = NULL;
	int ncams = 0;
	if (mocap_get_rig(c, &json, &ncams))
		return fail("rig");
	fputs(json, stdout);
	if (json[0] && json[strlen(json) - 1] != '\n')
		putchar('\n');
	free(json);
	return EXIT_OK;
}

static int cmd_skeleton(mocap_client *c)
{
	mocap_skeleton_def *s = malloc(sizeof(*s));
	if (!s)
		return EXIT_FAILED;
	int rc = mocap_get_skeleton(c, s);
	if (rc) {
		free(s);
		return fail("skeleton");
	}
	printf("skeleton %u: %d joints%s\n", s->id, s->njoints, s->rig_is_world ? " (rig frame = world frame)" : "");
	for (int j = 0; j < s->njoints; j++) {
		const mocap_joint_def *d = &s->joints[j];
		printf("  %2d %-16s parent %-16s offset %8.4f %8.4f %8.4f\n", j, d->name,
		       d->parent >= 0 ? s->joints[d->parent].name : "-", d->rest_offset[0], d->rest_offset[1],
		       d->rest_offset[2]);
	}
	free(s);
	return EXIT_OK;
}

static int cmd_control(mocap_client *c, mocap_command cmd, const char *arg, const char *what)
{
	char msg[1024];
	mocap_set_timeout(c, 120000); /* a reload may load models and build kernels */
	if (mocap_control(c, cmd, arg, msg, sizeof(msg)))
		return fail(what);
	printf("%s\n", msg[0] ? msg : "done");
	/* the daemon's reply names what a reload could not apply */
	return cmd == MOCAP_CMD_RELOAD && strstr(msg, "needs a restart: ") ? EXIT_RESTART : EXIT_OK;
}

/* The takes in the daemon's [record] directory, oldest first: the
 * directory, then the state (complete, recording or cut: a crash or a
 * power loss ended it), seconds and poses from its take.json. */
static int by_name(const struct dirent **a, const struct dirent **b) { return strcmp((*a)->d_name, (*b)->d_name); }

static int cmd_record_list(mocap_client *c)
{
	char dir[1024];
	if (mocap_control(c, MOCAP_CMD_RECORD_LIST, NULL, dir, sizeof(dir)))
		return fail("record list");
	dir[strcspn(dir, "\n")] = 0; /* the takes' names follow: read here with their details */
	struct dirent **names = NULL;
	int n = scandir(dir, &names, NULL, by_name);
	if (n < 0) {
		if (errno == ENOENT)
			return EXIT_OK; /* nothing recorded yet */
		fprintf(stderr, "mocapctl: record list: %s: %s\n", dir, strerror(errno));
		return EXIT_FAILED;
	}
	char recording[1024] = "";
	mocap_control(c, MOCAP_CMD_RECORD_STATUS, NULL, recording, sizeof(recording));
	for (int i = 0; i < n; i++) {
		char take[2200];
		take_info t;
		mc_err err;
		snprintf(take, sizeof(take), "%s/%s", dir, names[i]->d_name);
		if (names[i]->d_name[0] != '.' && take_info_read(take, &t, &err) == 0) {
			char prefix[2300];
			snprintf(prefix, sizeof(prefix), "recording %s:", take);
			const char *state = t.complete ? "complete" : !strncmp(recording, prefix, strlen(prefix)) ? "recording" : "cut";
			double secs = t.stop_realtime_ns > t.start_realtime_ns
					      ? (double)(t.stop_realtime_ns - t.start_realtime_ns) * 1e-9 : 0;
			printf("%s\t%s\t%.1f s\t%llu poses\n", take, state, secs, (unsigned long long)t.poses);
		}
		free(names[i]);
	}
	free(names);
	return EXIT_OK;
}

static int cmd_ping(mocap_client *c)
{
	uint64_t t0 = mocap_now_ns();
	if (mocap_ping(c, NULL))
		return fail("ping");
	printf("round trip %.3f ms\n", (double)(mocap_now_ns() - t0) * 1e-6);
	return EXIT_OK;
}

/* --version: this program's and, when one answers at path, the daemon's
 * (what it says in WELCOME, and the protocol version both speak).  Exits
 * 0 without a daemon too: the client's version is still the answer. */
static int print_versions(const char *path)
{
	printf("mocapctl (libmocap %s, protocol %d)\n", MOCAP_LIB_VERSION, MOCAP_PROTOCOL_VERSION);
	if (!path)
		path = mocap_default_socket();
	mocap_client *c = mocap_connect(path, "mocapctl --version");
	if (!c) {
		if (mocap_errcode() == MOCAP_E_NOT_RUNNING)
			printf("daemon: not running (at %s)\n", path);
		else
			printf("daemon: unknown: %s\n", mocap_errmsg());
		return EXIT_OK;
	}
	const char *v = mocap_daemon_version(c);
	printf("daemon: %s, protocol %d, at %s\n", v[0] ? v : "(it gives no version)", mocap_protocol_version(c), path);
	mocap_close(c);
	return EXIT_OK;
}

int main(int argc, char **argv)
{
	const char *path = NULL, *pos[5] = {0};
	int npos = 0;
	bool json = false, all = false, world = false, version = false;
	const char *name = NULL;
	long count = 0;
	for (int i = 1; i < argc; i++) {
		const char *a = argv[i];
		if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
			fputs(usage, stdout);
			return EXIT_OK;
		} else if (!strcmp(a, "--version") || !strcmp(a, "-V")) {
			version = true;
		} else if (!strcmp(a, "--socket") || !strcmp(a, "-s")) {
			if (++i >= argc) {
				fprintf(stderr, "mocapctl: %s needs a path\n%s", a, usage);
				return EXIT_USAGE;
			}
			path = argv[i];
		} else if (!strncmp(a, "--socket=", 9)) {
			path = a + 9;
		} else if (!strcmp(a, "--name")) {
			if (++i >= argc) {
				fprintf(stderr, "mocapctl: --name needs a take name\n%s", usage);
				return EXIT_USAGE;
			}
			name = argv[i];
		} else if (!strcmp(a, "--json")) {
			json = true;
		} else if (!strcmp(a, "--all")) {
			all = true;
		} else if (!strcmp(a, "--world")) {
			world = true;
		} else if (!strcmp(a, "--count") || !strncmp(a, "--count=", 8)) {
			const char *v = a[7] == '=' ? a + 8 : (++i < argc ? argv[i] : NULL);
			char *end;
			errno = 0;
			count = v ? strtol(v, &end, 10) : -1;
			if (!v || errno || *end || count < 1) {
				fprintf(stderr, "mocapctl: --count needs a positive number\n");
				return EXIT_USAGE;
			}
		} else if (a[0] == '-' && a[1] && !isdigit((unsigned char)a[1]) && a[1] != '.') { /* -90: a number */
			fprintf(stderr, "mocapctl: unknown option %s\n%s", a, usage);
			return EXIT_USAGE;
		} else if (npos < 5) {
			pos[npos++] = a;
		} else {
			fprintf(stderr, "mocapctl: too many arguments\n%s", usage);
			return EXIT_USAGE;
		}
	}
	if (version)
		return print_versions(path);
	if (!npos) {
		fputs(usage, stderr);
		return EXIT_USAGE;
	}
	const char *cmd = pos[0];
	bool known = !strcmp(cmd, "status") || !strcmp(cmd, "watch") || !strcmp(cmd, "rig") ||
		     !strcmp(cmd, "skeleton") || !strcmp(cmd, "reload") || !strcmp(cmd, "ping") ||
		     (!strcmp(cmd, "record") && npos >= 2 &&
		      (!strcmp(pos[1], "start") ||
		       ((!strcmp(pos[1], "stop") || !strcmp(pos[1], "status") || !strcmp(pos[1], "list")) && npos == 2))) ||
		     (!strcmp(cmd, "actor") && npos == 3 && !strcmp(pos[1], "save")) ||
		     (!strcmp(cmd, "steer") && npos >= 2);
	int max_pos = !strcmp(cmd, "record") || !strcmp(cmd, "actor") ? 3 : (!strcmp(cmd, "steer") ? 5 : 1);
	if (!known || npos > max_pos) {
		fprintf(stderr, "mocapctl: %s '%s'\n%s", known ? "too many arguments for" : "unknown command", cmd, usage);
		return EXIT_USAGE;
	}
	if (name && (strcmp(cmd, "record") || strcmp(pos[1], "start") || npos > 2)) {
		fprintf(stderr, "mocapctl: --name goes with record start (instead of a PATH)\n");
		return EXIT_USAGE;
	}
	if (((all || world || count) && strcmp(cmd, "watch")) || (json && strcmp(cmd, "watch") && strcmp(cmd, "status"))) {
		fprintf(stderr, "mocapctl: --all, --world and --count go with watch, --json with watch or status\n");
		return EXIT_USAGE;
	}

	if (!path)
		path = mocap_default_socket();
	mocap_client *c = mocap_connect(path, "mocapctl");
	if (!c)
		return fail(NULL);
	struct sigaction sa = {.sa_handler = on_signal};
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);

	int rc;
	if (!strcmp(cmd, "status"))
		rc = cmd_status(c, path, json);
	else if (!strcmp(cmd, "watch"))
		rc = cmd_watch(c, json, count, all, world);
	else if (!strcmp(cmd, "rig"))
		rc = cmd_rig(c);
	else if (!strcmp(cmd, "skeleton"))
		rc = cmd_skeleton(c);
	else if (!strcmp(cmd, "reload"))
		rc = cmd_control(c, MOCAP_CMD_RELOAD, NULL, "reload");
	else if (!strcmp(cmd, "ping"))
		rc = cmd_ping(c);
	else if (!strcmp(cmd, "actor"))
		rc = cmd_control(c, MOCAP_CMD_ACTOR_SAVE, pos[2], "actor save");
	else if (!strcmp(cmd, "steer")) {
		char target[256] = ""; /* the words after steer, one argument */
		for (int i = 1; i < npos; i++)
			snprintf(target + strlen(target), sizeof(target) - strlen(target), "%s%s", i > 1 ? " " : "", pos[i]);
		rc = cmd_control(c, MOCAP_CMD_STEER, target, "steer");
	}
	else if (!strcmp(pos[1], "start"))
		rc = cmd_control(c, MOCAP_CMD_RECORD_START, name ? name : npos > 2 ? pos[2] : "", "record start");
	else if (!strcmp(pos[1], "stop"))
		rc = cmd_control(c, MOCAP_CMD_RECORD_STOP, NULL, "record stop");
	else if (!strcmp(pos[1], "status"))
		rc = cmd_control(c, MOCAP_CMD_RECORD_STATUS, NULL, "record status");
	else
		rc = cmd_record_list(c);
	mocap_close(c);
	return rc;
}
