/* soak: runs mocapd for SOAK_S seconds (argument or $SOAK_S, default 3600)
 * under a steady client load and camera faults, and checks that it does
 * not leak (issue 20, deliverable 3).
 *
 * The daemon (started here, as tests/daemon/harness.h does) runs two sim
 * cameras playing tests/data/sim/walk_131_01_4s.bvh in a loop and one
 * fault-injecting camera (tests/drivers/faulty: periodic unplug, stalls,
 * dropped, corrupt, short and wrongly sized frames, failed opens), all at
 * 10 fps and small, with a cheap tracker, so that a loaded 2-core machine
 * keeps up.  Clients, all through libmocap (ipc/mocap.h):
 *
 *   - 8 watchers for the whole run, 4 in MOCAP_ALL and 4 in MOCAP_LATEST mode
 *   - 1 slow MOCAP_ALL client (a 4-frame queue, 300 ms per frame: it
 *     overflows all the time, so it lives on gaps)
 *   - 2 client processes (this program, --client) that are killed with
 *     SIGKILL every few seconds and started again
 *   - churn: every 10 s, 64 connections at once, half of them subscribe,
 *     then all close
 *   - status: mocap_get_status every 2 s; reload every 30 s, alternately
 *     mocap_control(MOCAP_CMD_RELOAD) and SIGHUP
 *
 * Every 5 s it samples /proc/<mocapd>/status (VmRSS, Threads) and
 * /proc/<mocapd>/fd; it prints a line per minute (per 10 s when the run is
 * shorter than 10 minutes) and at the end a verdict:
 *
 *   - RSS growth under 1 MB after the warm-up (the first 5 minutes; the
 *     first 30 s when the run is shorter than 10 minutes)
 *   - the daemon's open fds back to their count at the start
 *   - every MOCAP_ALL subscriber's frames plus GAPs (the frames' `missed`)
 *     equal to the frames published while it was subscribed (its span of
 *     seq, up to the last frame published before the end, which it must
 *     reach)
 *   - no watcher disconnected, the daemon alive and exiting 0 on SIGTERM
 *
 * Exit status 0 pass, 1 fail, 77 skip (mocapd or the plugins not built).
 * Run from the repository root (it needs tests/data/sim and config/). */
#include "soak_util.h"

#include <pthread.h>
#include <stdatomic.h>

#define SAMPLE_S 5
#define NWATCH 8
#define NKILLED 2
#define CHURN_N 64
#define MAX_SAMPLES 4096

/* ---- the client processes that are killed ----------------------------------- */

static int child_client(const char *sock, const char *mode)
{
	mocap_client *c = mocap_connect(sock, "soak-killed");
	if (!c)
		return 2;
	if (mocap_subscribe(c, strcmp(mode, "all") == 0 ? MOCAP_ALL : MOCAP_LATEST, MOCAP_SPACE_RIG, 0) != 0) {
		mocap_close(c);
		return 3;
	}
	mocap_skeleton_frame *f = malloc(sizeof(*f));
	int rc = 0;
	while (f && (rc = mocap_read_frame(c, f, 1000)) >= 0)
		;
	free(f);
	mocap_close(c);
	return 0;
}

/* ---- shared state ------------------------------------------------------------ */

static atomic_bool stop_clients;  /* watchers: stop once past final_seq */
static atomic_bool stop_load;     /* churn, status, reload, killed clients */
static _Atomic uint64_t final_seq; /* set at the end: the target every ALL watcher must reach */
static _Atomic uint64_t max_seq;   /* highest seq any watcher saw */
static _Atomic uint64_t give_up_ms; /* after stop_clients: when watchers stop waiting for final_seq */
static char sock_path[128];

typedef struct {
	int index;
	mocap_mode mode;
	bool slow;
	pthread_t thread;
	/* counted over the run (all sessions) */
	_Atomic uint64_t received, gaps, span, sessions, disconnects, errors;
	/* the current session */
	uint64_t first_seq, last_seq;
	bool in_session;
	bool reached_final;
	char last_error[256];
} watcher;

static void note_seq(uint64_t seq)
{
	uint64_t m = atomic_load(&max_seq);
	while (seq > m && !atomic_compare_exchange_weak(&max_seq, &m, seq))
		;
}

static void *watch_thread(void *arg)
{
	watcher *w = arg;
	mocap_skeleton_frame *f = malloc(sizeof(*f));
	if (!f)
		return NULL;
	char name[32];
	snprintf(name, sizeof(name), "soak-%s%d", w->slow ? "slow" : w->mode == MOCAP_ALL ? "all" : "latest", w->index);
	while (!atomic_load(&stop_clients)) {
		mocap_client *c = mocap_connect(sock_path, name);
		if (!c) {
			atomic_fetch_add(&w->errors, 1);
			snprintf(w->last_error, sizeof(w->last_error), "connect: %s", mocap_errmsg());
			mcd_sleep_ms(500);
			continue;
		}
		if (mocap_subscribe(c, w->mode, MOCAP_SPACE_RIG, w->slow ? 4 : 0) != 0) {
			atomic_fetch_add(&w->errors, 1);
			snprintf(w->last_error, sizeof(w->last_error), "subscribe: %s", mocap_errmsg());
			mocap_close(c);
			mcd_sleep_ms(500);
			continue;
		}
		atomic_fetch_add(&w->sessions, 1);
		w->in_session = false;
		for (;;) {
			uint64_t target = atomic_load(&final_seq);
			if (atomic_load(&stop_clients) &&
			    (w->mode != MOCAP_ALL || (target && w->in_session && w->last_seq >= target) ||
			     mcd_now_ms() > atomic_load(&give_up_ms)))
				break;
			int rc = mocap_read_frame(c, f, 200);
			if (rc == 0)
				continue;
			if (rc < 0) {
				atomic_fetch_add(&w->disconnects, 1);
				snprintf(w->last_error, sizeof(w->last_error), "read_frame: %s", mocap_errmsg());
				break;
			}
			note_seq(f->seq);
			if (!w->in_session) {
				w->in_session = true;
				w->first_seq = f->seq;
			} else if (w->mode == MOCAP_ALL && (!target || f->seq <= target)) {
				atomic_fetch_add(&w->gaps, f->missed);
			}
			if (!target || f->seq <= target || w->mode != MOCAP_ALL) {
				atomic_fetch_add(&w->received, 1);
				w->last_seq = f->seq;
			} else if (w->in_session && w->last_seq < target) {
				/* the first frame past the end: its gap may reach over
				 * it; only what it says about frames up to the end counts */
				uint64_t upto = target - w->last_seq;
				atomic_fetch_add(&w->gaps, f->missed < upto ? f->missed : upto);
				w->last_seq = target;
			}
			if (w->slow && !atomic_load(&stop_clients))
				mcd_sleep_ms(300);
		}
		if (w->in_session) {
			atomic_fetch_add(&w->span, w->last_seq - w->first_seq + 1);
			uint64_t target = atomic_load(&final_seq);
			w->reached_final = target && w->last_seq >= target;
		}
		w->in_session = false;
		mocap_close(c);
	}
	free(f);
	return NULL;
}

/* ---- load: churn, status, reload, killed clients ---------------------------- */

static atomic_ullong churn_rounds, churn_failures, status_calls, status_failures, reloads, reload_failures, kills;
static mcd_run run;
static char churn_error[256], status_error[256];

static void *churn_thread(void *arg)
{
	(void)arg;
	mocap_client **cs = calloc(CHURN_N, sizeof(*cs));
	while (cs && !atomic_load(&stop_load)) {
		for (int i = 0; i < CHURN_N; i++) {
			cs[i] = mocap_connect(sock_path, "soak-churn");
			if (!cs[i]) {
				atomic_fetch_add(&churn_failures, 1);
				snprintf(churn_error, sizeof(churn_error), "%s", mocap_errmsg());
			} else if (i % 2 && mocap_subscribe(cs[i], i % 4 == 1 ? MOCAP_ALL : MOCAP_LATEST, MOCAP_SPACE_RIG, 0)) {
				atomic_fetch_add(&churn_failures, 1);
				snprintf(churn_error, sizeof(churn_error), "subscribe: %s", mocap_errmsg());
			}
		}
		mcd_sleep_ms(300);
		for (int i = 0; i < CHURN_N; i++)
			if (cs[i])
				mocap_close(cs[i]);
		atomic_fetch_add(&churn_rounds, 1);
		for (int t = 0; t < 100 && !atomic_load(&stop_load); t++)
			mcd_sleep_ms(100);
	}
	free(cs);
	return NULL;
}

static void *status_thread(void *arg)
{
	(void)arg;
	mocap_daemon_status *st = malloc(sizeof(*st));
	mocap_client *c = NULL;
	int tick = 0;
	while (st && !atomic_load(&stop_load)) {
		if (!c)
			c = mocap_connect(sock_path, "soak-status");
		if (c) {
			if (mocap_get_status(c, st) == 0)
				atomic_fetch_add(&status_calls, 1);
			else {
				atomic_fetch_add(&status_failures, 1);
				snprintf(status_error, sizeof(status_error), "status: %s", mocap_errmsg());
				mocap_close(c);
				c = NULL;
			}
		}
		if (c && ++tick % 15 == 0) { /* every 30 s */
			char msg[256] = "";
			int rc;
			if ((tick / 15) % 2) {
				rc = mocap_control(c, MOCAP_CMD_RELOAD, "", msg, sizeof(msg));
			} else {
				mcd_run_signal(&run, SIGHUP);
				rc = 0;
			}
			atomic_fetch_add(rc == 0 ? &reloads : &reload_failures, 1);
			if (rc)
				snprintf(status_error, sizeof(status_error), "reload: %.120s %.120s", mocap_errmsg(), msg);
		}
		for (int t = 0; t < 20 && !atomic_load(&stop_load); t++)
			mcd_sleep_ms(100);
	}
	if (c)
		mocap_close(c);
	free(st);
	return NULL;
}

static pid_t spawn_child(const char *mode)
{
	pid_t pid = fork();
	if (pid == 0) {
		execl("/proc/self/exe", "soak", "--client", sock_path, mode, (char *)NULL);
		_exit(127);
	}
	return pid;
}

/* ---- sampling ----------------------------------------------------------------- */

/* The daemon's status through a fresh connection; false if unavailable. */
static bool daemon_status(mocap_daemon_status *st) { return soak_status(sock_path, st); }

/* True when every camera streams (state 0). */
static bool all_streaming(mocap_daemon_status *st)
{
	if (!daemon_status(st) || st->ncams < 3)
		return false;
	for (int i = 0; i < st->ncams; i++)
		if (st->cams[i].state != 0)
			return false;
	return true;
}

/* ---- config ------------------------------------------------------------------- */

/* A copy of config/rigs/ego_stereo.json with a third camera, "aux" (the
 * left camera again), for the fault-injecting camera. */
static const char rig_json[] =
	"{\"name\": \"soak\", \"kind\": \"egocentric\", \"cameras\": [\n"
	"{\"name\": \"left\", \"model\": \"equidistant\", \"width\": 256, \"height\": 256, \"f\": 81.48733086305042,"
	" \"cx\": 127.5, \"cy\": 127.5, \"k\": [0, 0, 0, 0], \"fov_deg\": 180,"
	" \"rig_from_cam\": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]},\n"
	"{\"name\": \"right\", \"model\": \"equidistant\", \"width\": 256, \"height\": 256, \"f\": 81.48733086305042,"
	" \"cx\": 127.5, \"cy\": 127.5, \"k\": [0, 0, 0, 0], \"fov_deg\": 180,"
	" \"rig_from_cam\": [[1, 0, 0, 0.3], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]},\n"
	"{\"name\": \"aux\", \"model\": \"equidistant\", \"width\": 256, \"height\": 256, \"f\": 81.48733086305042,"
	" \"cx\": 127.5, \"cy\": 127.5, \"k\": [0, 0, 0, 0], \"fov_deg\": 180,"
	" \"rig_from_cam\": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]}\n"
	"]}\n";

static bool copy_file(const char *from, const char *to)
{
	FILE *in = fopen(from, "rb"), *out = fopen(to, "wb");
	bool ok = in && out;
	char buf[65536];
	size_t n;
	while (ok && (n = fread(buf, 1, sizeof(buf), in)) > 0)
		ok = fwrite(buf, 1, n, out) == n;
	if (in)
		fclose(in);
	if (out && fclose(out) != 0)
		ok = false;
	return ok && chmod(to, 0755) == 0;
}

static char rig_path[256], plugin_dir[256], plugin_sim[320], plugin_faulty[320];

static bool write_config(const char *repo)
{
	snprintf(rig_path, sizeof(rig_path), "%s/rig.json", run.dir);
	snprintf(plugin_dir, sizeof(plugin_dir), "%s/plugins", run.dir);
	snprintf(plugin_sim, sizeof(plugin_sim), "%s/mocap-driver-sim.so", plugin_dir);
	snprintf(plugin_faulty, sizeof(plugin_faulty), "%s/mocap-driver-faulty.so", plugin_dir);
	char from[PATH_MAX + 64];
	if (!write_file(rig_path, rig_json) || mkdir(plugin_dir, 0755) != 0)
		return false;
	snprintf(from, sizeof(from), "%s/drivers/mocap-driver-sim.so", mcd_build_dir);
	if (!copy_file(from, plugin_sim))
		return false;
	snprintf(from, sizeof(from), "%s/mocap-driver-faulty.so", mcd_faulty_dir);
	if (!copy_file(from, plugin_faulty))
		return false;
	static char conf[16 * PATH_MAX], left[4 * PATH_MAX], right[4 * PATH_MAX];
	const char *sim_cam = "driver = sim\nbvh = %s/tests/data/sim/walk_131_01_4s.bvh\nrig = %s/config/rigs/ego_stereo.json\n"
			      "model = %s/config/models/default.json\nwidth = 32\nheight = 32\nrate = 10\nloop = true\n"
			      "epoch = %llu\n";
	/* Both sim cameras on the faulty camera's grid (multiples of 100 ms
	 * of CLOCK_MONOTONIC), their first frame 2 s from now, so that the
	 * three views of an instant have the same timestamp. */
	unsigned long long epoch = (mc_now_ns() / 100000000ull + 20) * 100000000ull;
	snprintf(left, sizeof(left), sim_cam, repo, repo, repo, epoch);
	snprintf(right, sizeof(right), sim_cam, repo, repo, repo, epoch);
	snprintf(conf, sizeof(conf),
		 "[daemon]\nplugin_dir = %s\nreopen_initial_ms = 100\nreopen_max_ms = 1000\nstall_timeout_ms = 2000\n"
		 "status_interval_s = 1\nstats_log_interval_s = 60\ngroup_tolerance_ms = 20\n"
		 "[socket]\npath = @SOCK@\nmax_clients = 128\n"
		 "[tracker]\nrig = %s\nmodel = %s/config/models/default.json\n"
		 "init_joints = %s/tests/data/ego_demo/gt.json\nwidth = 32\nheight = 32\niterations = 5\n"
		 "[camera left]\nrig_camera = left\ncamera = left\n%s"
		 "[camera right]\nrig_camera = right\ncamera = right\n%s"
		 "[camera aux]\ndriver = faulty\nrig_camera = aux\ndevice = SOAK\nwidth = 32\nheight = 32\nfps = 10\n"
		 "fail_open_count = 3\nunplug_every_s = 30\nunplug_ms = 2000\nstall_every = 290\nstall_ms = 1200\n"
		 "drop_every = 47\ncorrupt_every = 61\nshort_every = 83\nwrong_size_every = 101\n",
		 plugin_dir, rig_path, repo, repo, left, right);
	mcd_run_config(&run, conf);
	return true;
}

static void remove_extra_files(void)
{
	unlink(plugin_sim);
	unlink(plugin_faulty);
	rmdir(plugin_dir);
	unlink(rig_path);
}

/* ---- main --------------------------------------------------------------------- */

int main(int argc, char **argv)
{
	if (argc == 4 && strcmp(argv[1], "--client") == 0)
		return child_client(argv[2], argv[3]);
	setvbuf(stdout, NULL, _IOLBF, 0);
	signal(SIGPIPE, SIG_IGN);
	long soak_s = argc > 1 ? atol(argv[1]) : getenv("SOAK_S") ? atol(getenv("SOAK_S")) : 3600;
	if (soak_s < 60) {
		fprintf(stderr, "soak: SOAK_S must be at least 60 (got %ld)\n", soak_s);
		return 2;
	}
	bool short_run = soak_s < 600;
	long warmup_s = short_run ? 30 : 300, print_every_s = short_run ? 10 : 60;
	char repo[PATH_MAX];
	if (!mcd_find_build_up(3))
		return 77;
	if (!getcwd(repo, sizeof(repo)) || access("tests/data/sim/walk_131_01_4s.bvh", R_OK) != 0) {
		printf("soak: run from the repository root (tests/data/sim not found)\n");
		return 77;
	}
	char sim_so[PATH_MAX + 64];
	snprintf(sim_so, sizeof(sim_so), "%s/drivers/mocap-driver-sim.so", mcd_build_dir);
	if (access(sim_so, R_OK) != 0) {
		printf("soak: %s is not built\n", sim_so);
		return 77;
	}
	if (!mcd_run_init(&run) || !write_config(repo)) {
		fprintf(stderr, "soak: cannot set up %s\n", run.dir);
		return 1;
	}
	snprintf(sock_path, sizeof(sock_path), "%s", run.sock);
	if (!mcd_run_start(&run, NULL, NULL) || !mcd_run_wait_notify(&run, "READY=1", 60000)) {
		mcd_run_dump(&run, "start");
		remove_extra_files();
		mcd_run_cleanup(&run);
		return 1;
	}
	pid_t dpid = run.pid;
	uint64_t t0 = mcd_now_ms();
	printf("soak: %ld s, mocapd pid %d in %s; 2 sim cameras + 1 faulty, %d watchers (4 all, 4 latest), 1 slow, "
	       "%d killed clients, churn of %d, status every 2 s, reload every 30 s; warm-up %ld s\n",
	       soak_s, (int)dpid, run.dir, NWATCH, NKILLED, CHURN_N, warmup_s);

	/* the start: every camera streaming, no client yet */
	mocap_daemon_status *st = calloc(1, sizeof(*st));
	sample s0 = {0};
	for (int i = 0; i < 300 && !all_streaming(st); i++) {
		mcd_run_read_notify(&run);
		mcd_sleep_ms(100);
	}
	mcd_sleep_ms(300);
	sample_daemon(dpid, &s0);
	printf("start: rss %ld kB, %ld fds, %ld threads (after %.1f s)\n", s0.rss_kb, s0.fds, s0.threads,
	       (double)(mcd_now_ms() - t0) / 1000.0);

	watcher w[NWATCH + 1];
	memset(w, 0, sizeof(w));
	for (int i = 0; i <= NWATCH; i++) {
		w[i].index = i;
		w[i].mode = i < 4 || i == NWATCH ? MOCAP_ALL : MOCAP_LATEST;
		w[i].slow = i == NWATCH;
		pthread_create(&w[i].thread, NULL, watch_thread, &w[i]);
	}
	pthread_t churn, status;
	pthread_create(&churn, NULL, churn_thread, NULL);
	pthread_create(&status, NULL, status_thread, NULL);
	pid_t kids[NKILLED];
	for (int i = 0; i < NKILLED; i++)
		kids[i] = spawn_child(i % 2 ? "latest" : "all");

	static sample samples[MAX_SAMPLES];
	int ns = 0;
	sample base = {0}, peak = {0};
	bool have_base = false;
	uint64_t end = t0 + (uint64_t)soak_s * 1000;
	uint64_t next_sample = t0 + SAMPLE_S * 1000, next_kill = t0 + 3000, next_print = t0 + (uint64_t)print_every_s * 1000;
	int kill_turn = 0;
	bool daemon_died = false;
	while (mcd_now_ms() < end) {
		mcd_run_read_notify(&run); /* a full notify socket would block the daemon's sd_notify */
		if (run.notes_len > (1u << 20))
			run.notes_len = 0, run.notes[0] = 0;
		if (!mcd_run_alive(&run)) {
			daemon_died = true;
			break;
		}
		uint64_t now = mcd_now_ms();
		if (now >= next_kill) {
			int k = kill_turn++ % NKILLED;
			if (kids[k] > 0) {
				kill(kids[k], SIGKILL);
				waitpid(kids[k], NULL, 0);
				atomic_fetch_add(&kills, 1);
			}
			kids[k] = spawn_child(k % 2 ? "latest" : "all");
			next_kill = now + 1500 + (uint64_t)(rand() % 2000);
		}
		/* reap children that exited on their own */
		for (int k = 0; k < NKILLED; k++)
			if (kids[k] > 0 && waitpid(kids[k], NULL, WNOHANG) == kids[k])
				kids[k] = spawn_child(k % 2 ? "latest" : "all");
		if (now >= next_sample) {
			next_sample += SAMPLE_S * 1000;
			sample s;
			if (sample_daemon(dpid, &s)) {
				s.t = (double)(now - t0) / 1000.0;
				if (ns < MAX_SAMPLES)
					samples[ns++] = s;
				if (!have_base && s.t >= (double)warmup_s) {
					base = s;
					peak = s;
					have_base = true;
				}
				if (have_base && s.rss_kb > peak.rss_kb)
					peak = s;
			}
		}
		if (now >= next_print) {
			next_print += (uint64_t)print_every_s * 1000;
			sample s = {0};
			sample_daemon(dpid, &s);
			bool got = daemon_status(st);
			printf("t=%4.0fs rss %ld kB fds %ld threads %ld | published %llu (seq %llu, client drops %llu) |",
			       (double)(now - t0) / 1000.0, s.rss_kb, s.fds, s.threads,
			       got ? (unsigned long long)st->frames_published : 0ull, (unsigned long long)atomic_load(&max_seq),
			       got ? (unsigned long long)st->client_drops : 0ull);
			for (int i = 0; i <= NWATCH; i++)
				printf(" %s%d %llu/%llu", w[i].slow ? "slow" : w[i].mode == MOCAP_ALL ? "all" : "lat", i,
				       (unsigned long long)atomic_load(&w[i].received), (unsigned long long)atomic_load(&w[i].gaps));
			printf(" | kills %llu churn %llu reloads %llu status %llu", (unsigned long long)atomic_load(&kills),
			       (unsigned long long)atomic_load(&churn_rounds), (unsigned long long)atomic_load(&reloads),
			       (unsigned long long)atomic_load(&status_calls));
			if (got)
				for (int i = 0; i < st->ncams; i++)
					printf(" | %s %s %llu fr %llu drops", st->cams[i].name,
					       camera_state_name(st->cams[i].state),
					       (unsigned long long)st->cams[i].frames, (unsigned long long)st->cams[i].drops);
			printf("\n");
		}
		mcd_sleep_ms(50);
	}

	/* the end: load off, killed clients gone; every ALL watcher reads up to
	 * the last frame published so far, then all close */
	atomic_store(&stop_load, true);
	pthread_join(churn, NULL);
	pthread_join(status, NULL);
	for (int k = 0; k < NKILLED; k++)
		if (kids[k] > 0) {
			kill(kids[k], SIGKILL);
			waitpid(kids[k], NULL, 0);
		}
	mcd_sleep_ms(500);
	uint64_t target = atomic_load(&max_seq);
	atomic_store(&final_seq, target ? target : 1);
	atomic_store(&give_up_ms, mcd_now_ms() + 20000);
	atomic_store(&stop_clients, true);
	/* (the slow client stops sleeping: it drains what is queued for it) */
	for (int i = 0; i <= NWATCH; i++)
		pthread_join(w[i].thread, NULL);
	/* fds: back to the start once the clients are gone and the cameras
	 * stream again (the faulty one may be unplugged right now) */
	sample s_end = {0};
	mocap_daemon_status *st_end = calloc(1, sizeof(*st_end));
	bool streaming = false;
	for (int i = 0; i < 100 && !daemon_died; i++) {
		mcd_run_read_notify(&run);
		streaming = all_streaming(st_end);
		mcd_sleep_ms(200);
		if (!sample_daemon(dpid, &s_end)) {
			daemon_died = true;
			break;
		}
		if (streaming && s_end.fds == s0.fds)
			break;
	}
	s_end.t = (double)(mcd_now_ms() - t0) / 1000.0;
	if (!daemon_died && !daemon_status(st_end))
		memset(st_end, 0, sizeof(*st_end));

	/* the verdict */
	bool pass = !daemon_died;
	printf("\n---- soak verdict after %.0f s ----\n", s_end.t);
	if (daemon_died)
		printf("FAIL: mocapd died (wait status %d)\n", run.status);
	long growth = have_base ? s_end.rss_kb - base.rss_kb : 0;
	printf("RSS: start %ld kB, after the %ld s warm-up %ld kB, peak after it %ld kB (t=%.0f s), end %ld kB: "
	       "growth %+ld kB (limit < 1024 kB)\n",
	       s0.rss_kb, warmup_s, base.rss_kb, peak.rss_kb, peak.t, s_end.rss_kb, growth);
#if defined(__SANITIZE_ADDRESS__)
	/* ASan's quarantine holds freed memory back: RSS says nothing here. */
	printf("RSS not judged: built with AddressSanitizer\n");
	if (!have_base)
#else
	if (!have_base || growth >= 1024)
#endif
	{
		printf("FAIL: RSS grew by %ld kB after the warm-up\n", growth);
		pass = false;
	}
	printf("fds: start %ld, end %ld%s; threads: start %ld, end %ld\n", s0.fds, s_end.fds,
	       streaming ? "" : " (not every camera streaming at the end)", s0.threads, s_end.threads);
	if (s_end.fds != s0.fds) {
		printf("FAIL: mocapd has %ld fds, %ld at the start\n", s_end.fds, s0.fds);
		pass = false;
	}
	printf("published: seq 1..%llu to the clients (status: %llu frame sets published, %llu dropped, %llu client drops)\n",
	       (unsigned long long)target, (unsigned long long)st_end->frames_published,
	       (unsigned long long)st_end->frames_dropped, (unsigned long long)st_end->client_drops);
	for (int i = 0; i < st_end->ncams; i++)
		printf("camera %s: %llu frames, %llu drops\n", st_end->cams[i].name, (unsigned long long)st_end->cams[i].frames,
		       (unsigned long long)st_end->cams[i].drops);
	for (int i = 0; i <= NWATCH; i++) {
		watcher *x = &w[i];
		uint64_t rx = atomic_load(&x->received), gaps = atomic_load(&x->gaps), span = atomic_load(&x->span);
		const char *kind = x->slow ? "slow all" : x->mode == MOCAP_ALL ? "all" : "latest";
		printf("client %d (%s): %llu frames + %llu GAPs = %llu; published while subscribed %llu; sessions %llu, "
		       "disconnects %llu, errors %llu%s%s\n",
		       i, kind, (unsigned long long)rx, (unsigned long long)gaps, (unsigned long long)(rx + gaps),
		       (unsigned long long)span, (unsigned long long)atomic_load(&x->sessions),
		       (unsigned long long)atomic_load(&x->disconnects), (unsigned long long)atomic_load(&x->errors),
		       x->last_error[0] ? "; last error: " : "", x->last_error);
		if (x->mode == MOCAP_ALL && (rx + gaps != span || !x->reached_final)) {
			printf("FAIL: client %d: frames + GAPs %llu != %llu published%s\n", i, (unsigned long long)(rx + gaps),
			       (unsigned long long)span, x->reached_final ? "" : " (never reached the last frame)");
			pass = false;
		}
		if (x->mode == MOCAP_LATEST && rx == 0) {
			printf("FAIL: client %d received nothing\n", i);
			pass = false;
		}
		if (atomic_load(&x->disconnects) || atomic_load(&x->errors)) {
			printf("FAIL: client %d was disconnected or failed\n", i);
			pass = false;
		}
	}
	printf("load: %llu kills, %llu churn rounds of %d (%llu failures%s%s), %llu status calls (%llu failures), "
	       "%llu reloads (%llu failures)%s%s\n",
	       (unsigned long long)atomic_load(&kills), (unsigned long long)atomic_load(&churn_rounds), CHURN_N,
	       (unsigned long long)atomic_load(&churn_failures), churn_error[0] ? ": " : "", churn_error,
	       (unsigned long long)atomic_load(&status_calls), (unsigned long long)atomic_load(&status_failures),
	       (unsigned long long)atomic_load(&reloads), (unsigned long long)atomic_load(&reload_failures),
	       status_error[0] ? "; last: " : "", status_error);
	if (atomic_load(&churn_failures) || atomic_load(&status_failures) || atomic_load(&reload_failures))
		pass = false, printf("FAIL: churn, status or reload requests failed\n");
	if (target == 0)
		pass = false, printf("FAIL: nothing was published\n");
	int rc = -1;
	if (!daemon_died) {
		mcd_run_signal(&run, SIGTERM);
		rc = mcd_run_wait_exit(&run, 20000);
		printf("mocapd exit status on SIGTERM: %d\n", rc);
		if (rc != 0)
			pass = false, printf("FAIL: mocapd did not exit 0\n");
	}
	char *log = mcd_read_file(run.log);
	printf("mocapd log: %d lines, %d warnings, %d errors, %d reloads applied\n", log ? mcd_count(log, "\n") : 0,
	       log ? mcd_count(log, "warn") : 0, log ? mcd_count(log, "error") : 0,
	       log ? mcd_count(log, "reload: ") : 0);
	free(log);
	if (!pass || getenv("SOAK_KEEP_LOG")) {
		char keep[256];
		snprintf(keep, sizeof(keep), "/tmp/soak-mocapd-%d.log", (int)getpid());
		char *l = mcd_read_file(run.log);
		if (l && write_file(keep, l))
			printf("mocapd's log kept in %s\n", keep);
		free(l);
	}
	printf("samples (t s, rss kB, fds, threads):");
	for (int i = 0; i < ns; i += ns > 48 ? ns / 48 : 1)
		printf(" %.0f:%ld/%ld/%ld", samples[i].t, samples[i].rss_kb, samples[i].fds, samples[i].threads);
	printf("\nVERDICT: %s\n", pass ? "PASS" : "FAIL");
	free(st);
	free(st_end);
	remove_extra_files();
	mcd_run_cleanup(&run);
	return pass ? 0 : 1;
}
