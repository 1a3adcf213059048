/* mocap-vmc: streams mocapd's skeletons to VR and VTuber software over the
 * VMC protocol (OSC over UDP; VSeeFace, VNyan, Warudo, Virtual Motion
 * Capture and Unity apps listen on port 39539).  A client of mocapd: it
 * subscribes to the newest skeleton and sends, per frame or at a set rate,
 * one OSC bundle with /VMC/Ext/Root/Pos, /VMC/Ext/Bone/Pos for every
 * humanoid bone the skeleton has, /VMC/Ext/OK and /VMC/Ext/T.
 * docs/VMC.md. */
#include "base/mc_time.h"
#include "mc_install_paths.h" /* generated: MC_VERSION */
#include "mocap.h"
#include "vmc_config.h"
#include "vmc_map.h"

#include <getopt.h>
#include <lo/lo.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static volatile sig_atomic_t stop;
static void on_signal(int sig) { (void)sig; stop = 1; }

/* Exit codes: 1 mocapd went away or the network failed (systemd restarts
 * the unit), 2 bad usage, config or bone table (it would fail again). */
#define fail(code, ...) mc_fail_exit("mocap-vmc", code, __VA_ARGS__)

static void usage(FILE *f)
{
	fprintf(f,
		"usage: mocap-vmc [options]\n"
		"Sends mocapd's skeletons to a VMC protocol receiver (OSC over UDP; docs/VMC.md).\n"
		"\n"
		"  --socket PATH    the daemon's socket or tcp://HOST:PORT (default: $MOCAP_SOCKET,\n"
		"                   else %s)\n"
		"  --config FILE    settings, section [vmc] (default: none, built-in defaults)\n"
		"  --target HOST:PORT  the receiver (default 127.0.0.1:%d; [IPV6]:PORT)\n"
		"  --host HOST      the receiver's host alone\n"
		"  --port PORT      its UDP port alone\n"
		"  --rate HZ        bundles per second (default 0: one per tracked frame)\n"
		"  --bones FILE     bone table overrides, section [bones]\n"
		"  --set KEY=VALUE  any [vmc] setting (after --config)\n"
		"  --frames N       stop after N bundles (default 0: run until stopped)\n"
		"  --quiet          no progress lines, only errors and the statistics at exit\n"
		"  -h, --help       this text\n"
		"  -V, --version    the version\n",
		MOCAP_DEFAULT_SOCKET, VMC_DEFAULT_PORT);
}

typedef struct {
	const char *socket_path;
	long frames; /* 0: no limit */
	bool verbose;
	vmc_settings s;
} options;

static void set_or_fail(vmc_settings *s, const char *key, const char *value)
{
	mc_err err = {""};
	if (vmc_settings_set(s, key, value, &err) < 0)
		fail(2, "%s", err.msg);
}

static void parse_options(int argc, char **argv, options *o)
{
	enum { OPT_SOCKET = 256, OPT_CONFIG, OPT_TARGET, OPT_HOST, OPT_PORT, OPT_RATE, OPT_BONES, OPT_SET, OPT_FRAMES, OPT_QUIET };
	static const struct option opts[] = {
		{"socket", required_argument, NULL, OPT_SOCKET}, {"config", required_argument, NULL, OPT_CONFIG},
		{"target", required_argument, NULL, OPT_TARGET}, {"host", required_argument, NULL, OPT_HOST},
		{"port", required_argument, NULL, OPT_PORT},
		{"rate", required_argument, NULL, OPT_RATE},     {"bones", required_argument, NULL, OPT_BONES},
		{"set", required_argument, NULL, OPT_SET},       {"frames", required_argument, NULL, OPT_FRAMES},
		{"quiet", no_argument, NULL, OPT_QUIET},         {"help", no_argument, NULL, 'h'},
		{"version", no_argument, NULL, 'V'},             {NULL, 0, NULL, 0},
	};
	/* The config file first, whatever its place: options override it. */
	for (int i = 1; i + 1 < argc; i++)
		if (strcmp(argv[i], "--config") == 0) {
			mc_err err = {""};
			if (vmc_settings_load(&o->s, argv[i + 1], &err) < 0)
				fail(2, "%s", err.msg);
		}
	int c;
	while ((c = getopt_long(argc, argv, "hV", opts, NULL)) != -1) {
		char *end = NULL, key[64];
		const char *eq;
		switch (c) {
		case OPT_SOCKET: o->socket_path = optarg; break;
		case OPT_CONFIG: break;
		case OPT_TARGET: set_or_fail(&o->s, "target", optarg); break;
		case OPT_HOST: set_or_fail(&o->s, "host", optarg); break;
		case OPT_PORT: set_or_fail(&o->s, "port", optarg); break;
		case OPT_RATE: set_or_fail(&o->s, "rate", optarg); break;
		case OPT_BONES: set_or_fail(&o->s, "bones", optarg); break;
		case OPT_SET:
			eq = strchr(optarg, '=');
			if (!eq || eq == optarg || (size_t)(eq - optarg) >= sizeof(key))
				fail(2, "--set %s: expected KEY=VALUE", optarg);
			snprintf(key, sizeof(key), "%.*s", (int)(eq - optarg), optarg);
			set_or_fail(&o->s, key, eq + 1);
			break;
		case OPT_FRAMES:
			o->frames = strtol(optarg, &end, 10);
			if (!*optarg || *end || o->frames < 0)
				fail(2, "--frames %s: expected a count (0: no limit)", optarg);
			break;
		case OPT_QUIET: o->verbose = false; break;
		case 'h': usage(stdout); exit(0);
		case 'V': printf("mocap-vmc %s (libmocap %s)\n", MC_VERSION, MOCAP_LIB_VERSION); exit(0);
		default: usage(stderr); exit(2);
		}
	}
	if (optind < argc) {
		usage(stderr);
		fail(2, "unexpected argument '%s'", argv[optind]);
	}
}

/* ---- the stream ---- */

typedef struct {
	const options *o;
	vmc_bone_table table;
	mocap_client *c;
	lo_address to;
	mocap_skeleton_def sk;
	vmc_map map;
	vmc_hold hold;
	bool mapped;
	int checks_left;      /* frames whose forward kinematics is still checked */
	int last_space;
	uint64_t start_ns, received, sent, send_errors;
} stream;

/* A new skeleton definition: map its joints to bones again. */
static void remap(stream *st)
{
	if (mocap_get_skeleton(st->c, &st->sk) < 0)
		fail(1, "cannot get the skeleton from mocapd: %s", mocap_errmsg());
	mc_err err = {""};
	if (vmc_map_build(&st->map, &st->sk, &st->table, st->o->s.rest, &err) < 0)
		fail(2, "%s%s%s", st->o->s.bones[0] ? st->o->s.bones : "", st->o->s.bones[0] ? ": " : "", err.msg);
	st->mapped = true;
	memset(&st->hold, 0, sizeof(st->hold));
	st->checks_left = 30;
	if (st->o->verbose) {
		printf("mocap-vmc: skeleton %u: %d bones:", st->sk.id, st->map.nbones);
		for (int i = 0; i < st->map.nbones; i++)
			printf(" %s=%s", vmc_bone_name(st->map.bone[i].id), st->sk.joints[st->map.bone[i].pos_joint].name);
		printf("\n");
	}
}

static void add_transform(lo_bundle b, const char *path, const char *name, mc_vec3 p, mc_quat q)
{
	lo_message m = lo_message_new();
	lo_message_add_string(m, name);
	lo_message_add_float(m, (float)p.x);
	lo_message_add_float(m, (float)p.y);
	lo_message_add_float(m, (float)p.z);
	lo_message_add_float(m, (float)q.x);
	lo_message_add_float(m, (float)q.y);
	lo_message_add_float(m, (float)q.z);
	lo_message_add_float(m, (float)q.w);
	lo_bundle_add_message(b, path, m);
}

/* One bundle: the avatar root at the origin, every bone, the state and
 * the time (VMC protocol v2.5 "Performer"). */
static void send_frame(stream *st, const mocap_skeleton_frame *f)
{
	const vmc_settings *s = &st->o->s;
	vmc_up up = vmc_settings_up(s, f, &st->sk);
	double floor_height = vmc_settings_floor(s, up);
	vmc_bone_pose poses[VMC_NBONES];
	vmc_map_pose(&st->map, f, up, floor_height, poses);
	if (st->checks_left > 0 && st->checks_left-- && f->state == MOCAP_TRACK_OK) {
		double miss = vmc_map_residual(&st->map, f, up, floor_height, poses);
		if (miss > 0.005) {
			fprintf(stderr, "mocap-vmc: warning: the bones' forward kinematics misses a joint by %.0f mm: the "
					"bone table's rotation joints do not suit this skeleton (docs/VMC.md, \"Bones\")\n",
				miss * 1e3);
			st->checks_left = 0;
		}
	}
	vmc_hold_apply(&st->hold, &st->map, poses, s->min_confidence, s->low, s->ease_s, f->capture_ns);
	if ((int)f->space != st->last_space && st->o->verbose)
		printf("mocap-vmc: sending the %s frame (%s up)\n", f->space == MOCAP_SPACE_WORLD ? "world" : "rig",
		       up == VMC_UP_Y ? "y" : up == VMC_UP_Z ? "z" : "head");
	st->last_space = (int)f->space;

	lo_bundle b = lo_bundle_new(LO_TT_IMMEDIATE);
	add_transform(b, "/VMC/Ext/Root/Pos", "root", mc_v3(0, 0, 0), mc_quat_identity());
	for (int i = 0; i < st->map.nbones; i++)
		add_transform(b, "/VMC/Ext/Bone/Pos", vmc_bone_name(st->map.bone[i].id), poses[i].pos, poses[i].rot);
	lo_message ok = lo_message_new();
	lo_message_add_int32(ok, 1); /* loaded */
	lo_message_add_int32(ok, 3); /* calibration: done */
	lo_message_add_int32(ok, 0); /* calibration mode: normal */
	lo_message_add_int32(ok, f->state == MOCAP_TRACK_OK || f->state == MOCAP_TRACK_UNCERTAIN);
	lo_bundle_add_message(b, "/VMC/Ext/OK", ok);
	lo_message t = lo_message_new();
	lo_message_add_float(t, (float)((double)(mocap_now_ns() - st->start_ns) * 1e-9));
	lo_bundle_add_message(b, "/VMC/Ext/T", t);
	if (lo_send_bundle(st->to, b) < 0) {
		if (st->send_errors++ == 0)
			fprintf(stderr, "mocap-vmc: sending to %s:%d: %s (counted from now on)\n", s->host, s->port,
				lo_address_errstr(st->to));
	} else
		st->sent++;
	lo_bundle_free_recursive(b);
}

/* Reads frames until the next send is due (rate > 0) or one arrives. */
static void run(stream *st)
{
	const vmc_settings *s = &st->o->s;
	uint64_t period_ns = s->rate > 0 ? (uint64_t)(1e9 / s->rate) : 0, next_ns = mocap_now_ns();
	static mocap_skeleton_frame f, latest; /* 9 KB each: not on the stack */
	bool have = false;
	while (!stop && (st->o->frames == 0 || (long)st->sent < st->o->frames)) {
		int wait_ms = 1000;
		if (period_ns) {
			uint64_t now = mocap_now_ns();
			wait_ms = next_ns > now ? (int)((next_ns - now) / 1000000) : 0;
		}
		int rc = mocap_read_frame(st->c, &f, wait_ms);
		if (rc < 0) {
			if (stop)
				break;
			fail(1, "lost mocapd: %s", mocap_errmsg());
		}
		if (rc == 1) {
			st->received++;
			have = true;
			if (!st->mapped || f.skeleton_id != st->map.skeleton_id)
				remap(st);
			latest = f;
		}
		if (!have || (period_ns && mocap_now_ns() < next_ns) || (!period_ns && rc == 0))
			continue;
		send_frame(st, &latest);
		if (period_ns)
			next_ns += period_ns * (1 + (mocap_now_ns() - next_ns) / period_ns);
	}
}

int main(int argc, char **argv)
{
	options o = {.verbose = true};
	vmc_settings_default(&o.s);
	parse_options(argc, argv, &o);
	setvbuf(stdout, NULL, _IOLBF, 0);

	stream st = {.o = &o, .last_space = -1};
	vmc_bone_table_default(&st.table);
	mc_err err = {""};
	if (o.s.bones[0] && vmc_bone_table_load(&st.table, o.s.bones, &err) < 0)
		fail(2, "%s", err.msg);
	char port[16];
	snprintf(port, sizeof(port), "%d", o.s.port);
	st.to = lo_address_new(o.s.host, port);
	if (!st.to)
		fail(2, "cannot send to %s:%s", o.s.host, port);

	struct sigaction sa = {.sa_handler = on_signal};
	sigemptyset(&sa.sa_mask);
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);
	signal(SIGPIPE, SIG_IGN);

	st.c = mocap_connect(o.socket_path, "mocap-vmc");
	if (!st.c)
		fail(1, "cannot connect to mocapd: %s", mocap_errmsg());
	if (mocap_subscribe(st.c, MOCAP_LATEST, o.s.space, 0) < 0)
		fail(1, "cannot subscribe: %s", mocap_errmsg());
	if (o.verbose)
		printf("mocap-vmc: sending to %s:%d, %s\n", o.s.host, o.s.port,
		       o.s.rate > 0 ? "at a set rate" : "one bundle per frame");
	st.start_ns = mocap_now_ns();
	run(&st);

	double secs = (double)(mocap_now_ns() - st.start_ns) * 1e-9;
	printf("mocap-vmc: %.1f s, %llu frames received, %llu bundles sent (%.1f per s), %llu send errors\n", secs,
	       (unsigned long long)st.received, (unsigned long long)st.sent, secs > 0 ? (double)st.sent / secs : 0.0,
	       (unsigned long long)st.send_errors);
	mocap_close(st.c);
	lo_address_free(st.to);
	return 0;
}
