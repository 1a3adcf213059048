/* mocapd: the motion-capture daemon.
 *
 * Start-up: config -> socket server (adopting a systemd-passed socket) ->
 * tracker -> pipeline (plugins, capture threads) -> READY=1 once every
 * camera has had its first try at opening.  Then the main thread only
 * waits on signals (signalfd), control requests from clients and pipeline
 * events, and once per status interval refreshes STATUS=, the server's
 * status snapshot and, when every pipeline thread made progress, the
 * watchdog.  SIGTERM/SIGINT stop cleanly; SIGHUP (or `mocapctl reload`)
 * reloads what can change safely (docs/CONFIG.md).
 *
 * With [source] graph (docs/MOTION_GRAPH.md) there are no cameras, tracker
 * or pipeline: a graph source publishes graph walks, steered by STEER
 * control requests, and the main loop is the same. */
#include "actor.h"
#include "cl_cache.h"
#include "check.h"
#include "config.h"
#include "detector_thread.h"
#include "graph_source.h"
#include "log.h"
#include "network.h"
#include "server.h"
#include "notify.h"
#include "pipeline.h"
#include "probe.h"
#include "status.h"
#include "tree.h"
#include "tracker_setup.h"
#include "base/mc_time.h"

#include <errno.h>
#include <getopt.h>
#include <grp.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/signalfd.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <systemd/sd-daemon.h>
#include <unistd.h>

#ifndef MOCAPD_VERSION
#define MOCAPD_VERSION "0.1"
#endif
#include "mc_install_paths.h" /* generated: follows SYSCONFDIR at make install */
#define DEFAULT_CONFIG MC_INSTALL_SYSCONF_DIR "/mocapd.conf"
#define READY_TIMEOUT_S 20.0 /* READY=1 even if a camera is still trying */
#define STOP_GRACE_MS 3000

typedef struct {
	const char *config_path;
	const char *plugin_dir;
	const char *socket_path;
	const char *pose_dir;
	int log_level; /* -1: from the config */
	bool print;
	bool exit_at_end;
	bool offline; /* --offline: [daemon] offline, and --exit-at-end */
	bool check_only;
	bool probe;
} options;

typedef struct {
	options opt;
	mcd_config *cfg;
	srv_server *srv;
	mcd_tracking *tracking;
	mcd_pipeline *pipe;
	mcd_graph_source *graph; /* [source] graph instead of pipe */
	uint64_t graph_seen;     /* skeletons it had published at the last watchdog feed */
	int sigfd;
	uint64_t start_ns;
	bool ready;
	/* status bookkeeping */
	mcd_pipeline_status prev;
	uint64_t prev_ns, next_status_ns, next_stats_log_ns, next_watchdog_ns;
	uint64_t watchdog_usec;
	unsigned watchdog_misses;
} daemon_ctx;

static void usage(FILE *f)
{
	fprintf(f,
		"usage: mocapd [options]\n"
		"  -c, --config PATH      config file (default " DEFAULT_CONFIG ")\n"
		"      --plugin-dir DIR   driver plugin directory (overrides [daemon] plugin_dir)\n"
		"      --socket PATH      client socket (overrides [socket] path)\n"
		"  -l, --log-level LEVEL  error, warn, info or debug (overrides [daemon] log_level)\n"
		"  -p, --print            print every tracked skeleton as a text line on stdout\n"
		"      --exit-at-end      exit when every camera's stream has ended (files without loop)\n"
		"      --offline          track every frame set of recorded cameras as fast as the\n"
		"                         machine goes ([daemon] offline), then exit (--exit-at-end)\n"
		"      --save-poses DIR   write the tracker's actor model (DIR/actor.json) and every\n"
		"                         tracked pose (DIR/pose_<frame>.json) for tools/mocap-render\n"
		"      --check            check the config and the plugins, then exit\n"
		"      --probe            list the cameras every driver finds, their modes, and a\n"
		"                         [camera] section to paste for each, then exit\n"
		"  -V, --version\n"
		"  -h, --help\n"
		"Exit status: 0 ok, 1 error (config, start-up, a failed check), 2 bad usage.\n"
		"See mocapd(8) and mocapd.conf(5) (docs/CONFIG.md in the source) for the config file.\n");
}

enum { OPT_PLUGIN_DIR = 256, OPT_EXIT_AT_END, OPT_CHECK, OPT_SOCKET, OPT_SAVE_POSES, OPT_PROBE, OPT_OFFLINE };

/* One option of getopt_long: -1 to go on, else the exit status. */
static int take_option(int c, options *o)
{
	switch (c) {
	case 'c':
		o->config_path = optarg;
		return -1;
	case OPT_PLUGIN_DIR:
		o->plugin_dir = optarg;
		return -1;
	case OPT_SOCKET:
		if (strlen(optarg) >= 108) {
			fprintf(stderr, "mocapd: --socket: path too long (at most 107 bytes)\n");
			return 2;
		}
		o->socket_path = optarg;
		return -1;
	case OPT_SAVE_POSES:
		o->pose_dir = optarg;
		return -1;
	case 'l':
		o->log_level = mcd_log_parse_level(optarg);
		if (o->log_level < 0) {
			fprintf(stderr, "mocapd: --log-level: expected error, warn, info or debug, got '%s'\n", optarg);
			return 2;
		}
		return -1;
	case 'p':
		o->print = true;
		return -1;
	case OPT_EXIT_AT_END:
		o->exit_at_end = true;
		return -1;
	case OPT_OFFLINE:
		o->offline = o->exit_at_end = true;
		return -1;
	case OPT_CHECK:
		o->check_only = true;
		return -1;
	case OPT_PROBE:
		o->probe = true;
		return -1;
	case 'V':
		printf("mocapd %s (driver ABI %u)\n", MOCAPD_VERSION, (unsigned)MDRV_ABI_VERSION);
		return 0;
	case 'h':
		usage(stdout);
		return 0;
	default:
		usage(stderr);
		return 2;
	}
}

/* -1 to go on, else the exit status. */
static int parse_options(int argc, char **argv, options *o)
{
	static const struct option longs[] = {
		{"config", required_argument, NULL, 'c'},
		{"plugin-dir", required_argument, NULL, OPT_PLUGIN_DIR},
		{"socket", required_argument, NULL, OPT_SOCKET},
		{"save-poses", required_argument, NULL, OPT_SAVE_POSES},
		{"log-level", required_argument, NULL, 'l'},
		{"print", no_argument, NULL, 'p'},
		{"exit-at-end", no_argument, NULL, OPT_EXIT_AT_END},
		{"offline", no_argument, NULL, OPT_OFFLINE},
		{"check", no_argument, NULL, OPT_CHECK},
		{"probe", no_argument, NULL, OPT_PROBE},
		{"version", no_argument, NULL, 'V'},
		{"help", no_argument, NULL, 'h'},
		{NULL, 0, NULL, 0},
	};
	*o = (options){.config_path = DEFAULT_CONFIG, .log_level = -1};
	int c;
	while ((c = getopt_long(argc, argv, "c:l:pVh", longs, NULL)) != -1) {
		int rc = take_option(c, o);
		if (rc >= 0)
			return rc;
	}
	if (optind < argc) {
		fprintf(stderr, "mocapd: unexpected argument '%s'\n", argv[optind]);
		usage(stderr);
		return 2;
	}
	return -1; /* go on */
}

/* Loads the config and applies the command line over it.  With `all`
 * (--check), every error of the file is listed there. */
static mcd_config *load_config_all(const options *o, mcd_config_errors *all, mc_err *err)
{
	mcd_config *cfg = calloc(1, sizeof(*cfg));
	if (!cfg) {
		mc_err_set(err, "out of memory");
		return NULL;
	}
	if (mcd_config_load_all(o->config_path, cfg, all, err)) {
		free(cfg);
		return NULL;
	}
	char tree[PATH_MAX];
	if (o->plugin_dir)
		snprintf(cfg->plugin_dir, sizeof(cfg->plugin_dir), "%s", o->plugin_dir);
	else if (!mcd_config_is_set(cfg, "daemon", "plugin_dir") && mcd_tree_plugin_dir_self(tree, sizeof(tree))) {
		mcd_info("running from a build tree: driver plugins from %s", tree);
		snprintf(cfg->plugin_dir, sizeof(cfg->plugin_dir), "%s", tree);
	}
	if (o->socket_path)
		snprintf(cfg->socket.path, sizeof(cfg->socket.path), "%s", o->socket_path);
	if (o->log_level >= 0)
		cfg->log_level = o->log_level;
	if (o->print)
		cfg->print = true;
	if (o->offline)
		cfg->offline = true;
	return cfg;
}

static mcd_config *load_config(const options *o, mc_err *err)
{
	return load_config_all(o, NULL, err);
}

/* ---- start-up ---------------------------------------------------------------------- */

static int block_signals(daemon_ctx *d, mc_err *err)
{
	/* Blocked before any thread starts, so that every thread inherits the
	 * mask and only the signalfd sees them. */
	sigset_t set;
	sigemptyset(&set);
	sigaddset(&set, SIGTERM);
	sigaddset(&set, SIGINT);
	sigaddset(&set, SIGHUP);
	if (pthread_sigmask(SIG_BLOCK, &set, NULL) != 0)
		return mc_err_set(err, "cannot block signals");
	signal(SIGPIPE, SIG_IGN); /* a client that went away is an error return, not death */
	d->sigfd = signalfd(-1, &set, SFD_CLOEXEC | SFD_NONBLOCK);
	if (d->sigfd < 0)
		return mc_err_set(err, "signalfd: %s", strerror(errno));
	return 0;
}

/* The listening socket systemd passed (socket activation), or -1. */
static int passed_socket(const char *path, mc_err *err)
{
	int n = sd_listen_fds(1);
	if (n < 0)
		return mc_err_set(err, "sd_listen_fds: %s", strerror(-n)), -2;
	if (n == 0)
		return -1;
	if (n > 1)
		return mc_err_set(err, "socket activation: %d sockets passed, mocapd takes one", n), -2;
	int fd = SD_LISTEN_FDS_START;
	if (sd_is_socket_unix(fd, SOCK_SEQPACKET, 1, NULL, 0) <= 0)
		return mc_err_set(err,
				  "socket activation: the passed fd is not a listening SOCK_SEQPACKET Unix socket "
				  "(mocapd.socket needs ListenSequentialPacket=%s)",
				  path),
		       -2;
	return fd;
}

/* The server's word on each client that connects (PROTOCOL.md: HELLO's
 * client_name is shown in the log). */
static void log_client(void *ctx, const char *line)
{
	(void)ctx;
	mcd_info("%s", line);
}

/* Who may connect: users get "permission denied" from the socket's mode
 * and group, so the log names both (and the command that lets one in). */
static void log_socket_access(const char *path, bool from_systemd)
{
	struct stat st;
	const char *how = from_systemd ? " (from systemd)" : "";
	if (stat(path, &st) != 0) {
		mcd_info("socket: %s%s", path, how);
		return;
	}
	struct group *gr = getgrgid(st.st_gid);
	char group[64];
	if (gr)
		snprintf(group, sizeof(group), "%s", gr->gr_name);
	else
		snprintf(group, sizeof(group), "%u", (unsigned)st.st_gid);
	if (st.st_mode & S_IWOTH)
		mcd_info("socket: %s%s, mode %04o: any local user may connect", path, how,
			 (unsigned)(st.st_mode & 07777));
	else
		mcd_info("socket: %s%s, group %s, mode %04o: clients must run as its owner or in group %s "
			 "(sudo usermod -aG %s USER, then log in again)",
			 path, how, group, (unsigned)(st.st_mode & 07777), group, group);
}

static int start_server(daemon_ctx *d, mc_err *err)
{
	const mcd_config *cfg = d->cfg;
	if (!cfg->socket.enabled) {
		mcd_info("socket: disabled in the config");
		return 0;
	}
	srv_config sc;
	srv_config_default(&sc);
	snprintf(sc.path, sizeof(sc.path), "%s", cfg->socket.path);
	sc.listen_fd = passed_socket(cfg->socket.path, err);
	if (sc.listen_fd == -2)
		return -1;
	sc.max_clients = cfg->socket.max_clients;
	sc.socket_mode = cfg->socket.mode;
	snprintf(sc.daemon_version, sizeof(sc.daemon_version), "mocapd %s", MOCAPD_VERSION);
	sc.on_client = log_client;
	if (cfg->socket.group[0]) {
		struct group *gr = getgrnam(cfg->socket.group);
		if (!gr) {
			char where[700];
			return mc_err_set(err, "%s: no such group '%s'",
					  mcd_config_where(cfg, "socket", "group", where, sizeof(where)),
					  cfg->socket.group);
		}
		sc.control_gid = gr->gr_gid;
	}
	if (mcd_network_apply(cfg, &sc, err))
		return -1;
	d->srv = srv_create(&sc, err);
	if (!d->srv) {
		char where[700];
		if (sc.tcp_listen[0] && strstr(err->msg, "TCP listener"))
			mc_err_prefix(err, "%s", mcd_config_where(cfg, "network", "listen", where, sizeof(where)));
		return -1;
	}
	log_socket_access(cfg->socket.path, sc.listen_fd >= 0);
	if (sc.tcp_listen[0])
		mcd_info("network: TCP clients on %s (port %d), with the token of %s%s", sc.tcp_listen,
			 srv_tcp_port(d->srv), cfg->network.token_file,
			 sc.tcp_privileged ? "; they may control the daemon" : "");
	return 0;
}

static int start_tracking(daemon_ctx *d, mc_err *err)
{
	if (!d->cfg->tracker.enabled) {
		mcd_info("tracker: disabled in the config; frames are captured and grouped only");
		return 0;
	}
	d->tracking = calloc(1, sizeof(*d->tracking));
	if (!d->tracking)
		return mc_err_set(err, "out of memory");
	if (mcd_tracking_setup(d->cfg, d->tracking, err)) {
		free(d->tracking);
		d->tracking = NULL;
		return -1;
	}
	if (d->opt.pose_dir) {
		char path[4200];
		snprintf(path, sizeof(path), "%s/actor.json", d->opt.pose_dir);
		if (mc_model_save(mc_tracker_model(d->tracking->tracker), path, err))
			return mc_err_prefix(err, "--save-poses");
	}
	if (d->srv) {
		if (srv_set_skeleton_def_from_model(d->srv, mc_tracker_model(d->tracking->tracker), err))
			return -1;
		if (d->tracking->rig_json &&
		    srv_set_rig(d->srv, d->tracking->rig_json, d->tracking->rig.ncams, err))
			return -1;
	}
	return 0;
}

/* ---- status, watchdog -------------------------------------------------------------- */

static void refresh_status(daemon_ctx *d, uint64_t now)
{
	if (d->graph) {
		srv_status ss;
		mcd_graph_source_status(d->graph, &ss);
		char line[160];
		snprintf(line, sizeof(line), "%llu skeletons from the graph", (unsigned long long)ss.frames_published);
		mcd_notify_status(line);
		if (d->srv)
			srv_set_status(d->srv, &ss);
		return;
	}
	mcd_pipeline_status st;
	bool log_now = d->cfg->stats_log_interval_s > 0 && now >= d->next_stats_log_ns;
	mcd_pipeline_get_status(d->pipe, &st, true);
	double dt = (double)(now - d->prev_ns) / 1e9;
	char line[1100];
	mcd_status_line(&st, &d->prev, dt, line, sizeof(line));
	mcd_notify_status(line);
	if (log_now) {
		mcd_info("status: %s", line);
		d->next_stats_log_ns = now + (uint64_t)(d->cfg->stats_log_interval_s * 1e9);
	}
	if (d->srv) {
		srv_status ss;
		mcd_status_to_server(&st, &d->prev, dt, d->start_ns,
				     d->tracking ? mc_tracker_device_name(d->tracking->tracker) : "", &ss);
		ss.recording = mcd_pipeline_recording(d->pipe);
		srv_set_status(d->srv, &ss);
	}
	d->prev = st;
	d->prev_ns = now;
}

static void feed_watchdog(daemon_ctx *d)
{
	if (d->graph) { /* progress: skeletons published since the last feed */
		uint64_t n = mcd_graph_source_published(d->graph);
		if (n != d->graph_seen) {
			mcd_notify_watchdog();
			d->watchdog_misses = 0;
		} else if (d->watchdog_misses++ == 0) {
			mcd_error("watchdog: the graph source made no progress; not feeding the watchdog");
		}
		d->graph_seen = n;
		return;
	}
	char stuck[128];
	if (mcd_pipeline_progress(d->pipe, stuck, sizeof(stuck))) {
		mcd_notify_watchdog();
		d->watchdog_misses = 0;
	} else if (d->watchdog_misses++ == 0)
		mcd_error("watchdog: the %s made no progress; not feeding the watchdog", stuck);
}

/* ---- reload ------------------------------------------------------------------------- */

static int reload(daemon_ctx *d, char *msg, size_t cap)
{
	mcd_notify_reloading();
	mc_err err = {{0}};
	mcd_config *neu = load_config(&d->opt, &err);
	int rc = 0;
	if (!neu) {
		mcd_error("reload: %s; keeping the running config", err.msg);
		snprintf(msg, cap, "%s", err.msg);
		rc = -1;
	} else {
		/* Take what a reload can change (the config table says which);
		 * keep, and name, what takes a restart. */
		char changes[780];
		mcd_config_take_reloadable(d->cfg, neu, changes, sizeof(changes));
		mcd_log_set_level(d->cfg->log_level);
		if (d->pipe)
			mcd_pipeline_reload(d->pipe, d->cfg);
		mcd_info("reload: %s applied (log level %s)", d->opt.config_path, mcd_log_level_name(neu->log_level));
		snprintf(msg, cap, "reloaded %.200s: %.780s", d->opt.config_path, changes);
		free(neu);
	}
	mcd_notify_ready("running");
	return rc;
}

/* ---- the main loop ------------------------------------------------------------------------ */

/* Returns 1 to stop. */
static int handle_signals(daemon_ctx *d)
{
	struct signalfd_siginfo si;
	while (read(d->sigfd, &si, sizeof(si)) == (ssize_t)sizeof(si)) {
		if (si.ssi_signo == SIGHUP) {
			char msg[1024]; /* a control reply: PROTO_TEXT_MAX + 1 */
			mcd_info("SIGHUP: reloading %s", d->opt.config_path);
			reload(d, msg, sizeof(msg));
		} else {
			mcd_info("%s: shutting down", strsignal((int)si.ssi_signo));
			return 1;
		}
	}
	return 0;
}

static void handle_requests(daemon_ctx *d)
{
	if (!d->srv)
		return;
	srv_control ctl;
	while (srv_poll_control(d->srv, &ctl) == 1) {
		char msg[1024]; /* a control reply: PROTO_TEXT_MAX + 1 */
		int rc;
		if (ctl.command == MC_CONTROL_STEER) {
			mcd_info("steer '%s' requested by pid %d (uid %u)", ctl.argument, (int)ctl.pid, (unsigned)ctl.uid);
			if (d->graph) {
				rc = mcd_graph_source_steer(d->graph, ctl.argument, msg, sizeof(msg));
			} else {
				snprintf(msg, sizeof(msg), "this mocapd has no [source] graph to steer");
				rc = -1;
			}
		} else if (ctl.command == MC_CONTROL_RELOAD) {
			mcd_info("reload requested by pid %d (uid %u)", (int)ctl.pid, (unsigned)ctl.uid);
			rc = reload(d, msg, sizeof(msg));
		} else if (!d->pipe) {
			snprintf(msg, sizeof(msg), "this mocapd streams a [source] graph: no tracker, no cameras to record");
			rc = -1;
		} else if (ctl.command == MC_CONTROL_ACTOR_SAVE) {
			mcd_info("actor save '%s' requested by pid %d (uid %u)", ctl.argument, (int)ctl.pid,
				 (unsigned)ctl.uid);
			rc = mcd_actor_save(d->pipe, d->cfg, ctl.argument, msg, sizeof(msg));
		} else {
			if (ctl.command == MC_CONTROL_RECORD_START || ctl.command == MC_CONTROL_RECORD_STOP)
				mcd_info("record %s requested by pid %d (uid %u)",
					 ctl.command == MC_CONTROL_RECORD_START ? "start" : "stop", (int)ctl.pid,
					 (unsigned)ctl.uid);
			rc = mcd_pipeline_record(d->pipe, (int)ctl.command, ctl.argument, msg, sizeof(msg));
			/* STATUS is a snapshot refreshed every status_interval_s;
			 * its recording flag must not lag a start or stop. */
			srv_set_recording(d->srv, mcd_pipeline_recording(d->pipe));
		}
		srv_control_done(d->srv, ctl.token, rc, msg);
	}
}

static void maybe_ready(daemon_ctx *d, uint64_t now)
{
	if (d->ready)
		return;
	if (d->graph) { /* no cameras to wait for */
		d->ready = true;
		mcd_notify_ready("streaming graph walks");
		mcd_info("ready: streaming graph walks");
		return;
	}
	bool timed_out = (double)(now - d->start_ns) / 1e9 > READY_TIMEOUT_S;
	if (!mcd_pipeline_cameras_attempted(d->pipe) && !timed_out)
		return;
	d->ready = true;
	mcd_pipeline_get_status(d->pipe, &d->prev, false);
	d->prev_ns = now;
	char line[1100];
	mcd_status_line(&d->prev, &d->prev, 0, line, sizeof(line));
	mcd_notify_ready(line);
	mcd_info("ready: %s", line);
}

/* What is due at `now`: READY=1, the status refresh, the watchdog. */
static void do_timers(daemon_ctx *d, uint64_t now)
{
	maybe_ready(d, now);
	if (d->ready && now >= d->next_status_ns) {
		refresh_status(d, now);
		d->next_status_ns = now + (uint64_t)(d->cfg->status_interval_s * 1e9);
	}
	if (d->ready && d->watchdog_usec && now >= d->next_watchdog_ns) {
		feed_watchdog(d);
		d->next_watchdog_ns = now + d->watchdog_usec * 1000 / 2;
	}
	if (d->pipe)
		mcd_pipeline_offline_progress(d->pipe, now, false);
}

/* How long to poll: until the next timer, at most a second. */
static int poll_timeout_ms(const daemon_ctx *d, uint64_t now)
{
	uint64_t wake = d->ready ? d->next_status_ns : now + 50 * MC_NS_PER_MS;
	if (d->watchdog_usec && d->ready && d->next_watchdog_ns < wake)
		wake = d->next_watchdog_ns;
	int timeout_ms = wake > now ? (int)((wake - now) / MC_NS_PER_MS) + 1 : 0;
	return timeout_ms > 1000 ? 1000 : timeout_ms;
}

/* The last word on the frame sets: how many were tracked, skipped and
 * why, and the capture-to-publish latency (the demo's summary reads it). */
static void log_totals(daemon_ctx *d)
{
	if (!d->pipe)
		return;
	mcd_pipeline_status *st = calloc(1, sizeof(*st));
	if (!st)
		return;
	if (d->cfg->offline) { /* frames carry their time in the recording: no latency to tell */
		mcd_pipeline_offline_progress(d->pipe, mc_now_ns(), true);
		free(st);
		return;
	}
	mcd_pipeline_get_status(d->pipe, st, false);
	const srv_latency_status *l = &st->latency;
	mcd_info("totals: %llu frame sets tracked; skipped: %llu behind (a newer set was due), %llu stale (over "
		 "max_frame_age_ms); %llu without every camera; capture to publish %.1f ms p50, %.1f ms p99 "
		 "(last %u sets)",
		 (unsigned long long)st->track.tracked, (unsigned long long)l->skipped_behind,
		 (unsigned long long)l->skipped_stale, (unsigned long long)l->incomplete, l->stage[SRV_LAT_TOTAL].p50,
		 l->stage[SRV_LAT_TOTAL].p99, l->window);
	free(st);
}

static int run(daemon_ctx *d)
{
	for (;;) {
		uint64_t now = mc_now_ns();
		do_timers(d, now);
		if (d->opt.exit_at_end && d->pipe && mcd_pipeline_finished(d->pipe)) {
			if (mcd_pipeline_all_failed(d->pipe)) {
				mcd_error("every camera has failed for good; exiting with status 1 (--exit-at-end)");
				return 1;
			}
			mcd_info("every stream has ended; exiting (--exit-at-end)");
			return 0;
		}
		struct pollfd fds[3] = {
			{.fd = d->sigfd, .events = POLLIN},
			{.fd = d->pipe ? mcd_pipeline_event_fd(d->pipe) : -1, .events = POLLIN},
			{.fd = d->srv ? srv_event_fd(d->srv) : -1, .events = POLLIN},
		};
		if (poll(fds, 3, poll_timeout_ms(d, now)) < 0 && errno != EINTR) {
			mcd_error("poll: %s", strerror(errno));
			return 1;
		}
		if ((fds[0].revents & POLLIN) && handle_signals(d))
			return 0;
		if ((fds[1].revents & POLLIN) && mcd_pipeline_take_events(d->pipe))
			mcd_pipeline_share_rings(d->pipe);
		if (fds[2].revents & POLLIN)
			handle_requests(d);
	}
}

static void shutdown_all(daemon_ctx *d)
{
	mcd_notify_stopping();
	mcd_graph_source_stop(d->graph); /* before the server it publishes to */
	if (d->pipe) {
		mcd_pipeline_stop(d->pipe, STOP_GRACE_MS);
		mcd_pipeline_destroy(d->pipe);
	}
	srv_destroy(d->srv);
	if (d->tracking) {
		mcd_tracking_free(d->tracking);
		free(d->tracking);
	}
	if (d->sigfd >= 0)
		close(d->sigfd);
	free(d->cfg);
}

/* The plugin directory, before the OpenCL kernels are built (which takes
 * seconds): a daemon run from a build tree with the installed default
 * should fail at once and say which option mends it. */
static int check_plugin_dir(const mcd_config *cfg, mc_err *err)
{
	if (cfg->source.graph[0] || cfg->ncams == 0 || access(cfg->plugin_dir, R_OK | X_OK) == 0)
		return 0;
	char where[PATH_MAX + 64];
	return mc_err_set(err, "%s: driver plugin directory %s: %s; give one with --plugin-dir DIR (in a build tree: "
			       "--plugin-dir build/drivers)",
			  mcd_config_is_set(cfg, "daemon", "plugin_dir")
				  ? mcd_config_where(cfg, "daemon", "plugin_dir", where, sizeof(where))
				  : "[daemon] plugin_dir (the built-in default)",
			  cfg->plugin_dir, strerror(errno));
}

static int start(daemon_ctx *d, mc_err *err)
{
	if (check_plugin_dir(d->cfg, err))
		return -1;
	d->watchdog_usec = mcd_watchdog_usec();
	if (block_signals(d, err))
		return -1;
	if (start_server(d, err))
		return -1;
	if (d->watchdog_usec)
		mcd_notify_watchdog(); /* start-up progress (building OpenCL kernels takes a while) */
	if (d->cfg->source.graph[0]) {
		d->graph = mcd_graph_source_start(d->cfg, d->srv, err);
		return d->graph ? 0 : -1;
	}
	if (start_tracking(d, err))
		return -1;
	if (d->watchdog_usec)
		mcd_notify_watchdog();
	d->pipe = mcd_pipeline_create(d->cfg, d->tracking, d->srv, err);
	if (!d->pipe || mcd_pipeline_start(d->pipe, d->tracking ? d->opt.pose_dir : NULL, err))
		return -1;
	mcd_pipeline_share_rings(d->pipe);
	return 0;
}

/* --check's loading: every error of the file. */
static mcd_config *load_for_check(const options *o, mc_err *err)
{
	mcd_config_errors all = {.cap = 16384};
	all.buf = calloc(1, all.cap);
	mcd_config *cfg = all.buf ? load_config_all(o, &all, err) : load_config(o, err);
	if (!cfg && all.buf && all.n > 0) {
		for (char *line = all.buf, *nl; *line; line = nl + 1) {
			nl = strchr(line, '\n');
			*nl = 0;
			mcd_error("%s", line);
		}
		if (all.untold)
			mcd_error("... and %d more", all.untold);
		mc_err_set(err, "%s: %d error%s", o->config_path, all.n, all.n == 1 ? "" : "s");
	}
	free(all.buf);
	return cfg;
}

/* --probe: the plugin directory is --plugin-dir's, else the config's if
 * the config loads (a missing config is no reason not to probe), else the
 * build tree's or the built-in one.  Returns the exit status. */
static int probe(const options *o)
{
	char dir[PATH_MAX];
	mc_err err = {{0}};
	mcd_config *cfg = o->plugin_dir ? NULL : load_config(o, &err);
	if (o->plugin_dir)
		snprintf(dir, sizeof(dir), "%s", o->plugin_dir);
	else if (cfg)
		snprintf(dir, sizeof(dir), "%s", cfg->plugin_dir);
	else if (!mcd_tree_plugin_dir_self(dir, sizeof(dir)))
		snprintf(dir, sizeof(dir), "%s", MC_INSTALL_PLUGIN_DIR);
	free(cfg);
	int n = mcd_probe_all(dir, stdout, &err);
	if (n < 0) {
		mcd_error("%s", err.msg);
		return 1;
	}
	if (n == 0)
		printf("no cameras found.  USB cameras need read-write access to /dev/video* (group video); GigE "
		       "cameras must be on this host's subnet; see README.md, \"First real camera\".\n");
	return 0;
}

int main(int argc, char **argv)
{
	daemon_ctx d = {.sigfd = -1};
	int rc = parse_options(argc, argv, &d.opt);
	if (rc >= 0)
		return rc;
	mcd_log_init();
	if (d.opt.log_level >= 0)
		mcd_log_set_level(d.opt.log_level);
	if (d.opt.probe)
		return probe(&d.opt);
	mc_err err = {{0}};
	d.cfg = d.opt.check_only ? load_for_check(&d.opt, &err) : load_config(&d.opt, &err);
	if (!d.cfg) {
		mcd_error("%s", err.msg);
		mcd_notify_status(err.msg);
		return 1;
	}
	mcd_log_set_level(d.cfg->log_level);
	d.start_ns = mc_now_ns();
	char note[PATH_MAX + 400];
	if (mcd_cl_cache_setup(note, sizeof(note)) != 0 && d.cfg->tracker.enabled && !d.cfg->source.graph[0]) {
		mcd_error("%s", note);
		free(d.cfg);
		return 1;
	}
	if (note[0])
		mcd_info("%s", note);
	if (d.opt.check_only) {
		rc = mcd_check(d.cfg, d.opt.config_path);
		free(d.cfg);
		return rc;
	}
	mcd_info("mocapd %s starting with %s", MOCAPD_VERSION, d.opt.config_path);
	if (start(&d, &err)) {
		mcd_error("%s", err.msg);
		mcd_notify_status(err.msg);
		shutdown_all(&d);
		return 1;
	}
	rc = run(&d);
	log_totals(&d);
	shutdown_all(&d);
	mcd_info("stopped");
	return rc;
}
