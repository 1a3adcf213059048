/* mocapd as a process: a run to the end of finite streams, config and
 * plugin errors at start-up, SIGTERM, SIGHUP reload, SIGKILL then restart
 * (no stale socket or lock), a second instance, socket activation. */
#include "daemon/harness.h"
#include "image/mc_draw.h"
#include "test_util.h"

#include <jansson.h>

#define BASE BASE_WITH("")
#define BASE_WITH(daemon_keys)               \
	"[daemon]\n" daemon_keys             \
	"plugin_dir = @FAULTY@\n"            \
	"reopen_initial_ms = 50\n"           \
	"reopen_max_ms = 200\n"              \
	"[socket]\n"                         \
	"path = @SOCK@\n"                    \
	"[tracker]\n"                        \
	"enabled = false\n"

#define TWO_CAMS                             \
	"[camera a]\n"                       \
	"driver = faulty\n"                  \
	"device = A\n"                       \
	"[camera b]\n"                       \
	"driver = faulty\n"                  \
	"device = B\n"                       \
	"format = mjpeg\n"

static const char *const print_args[] = {"--print", NULL};
static char repo_dir[PATH_MAX]; /* the repository root: tests run from there */

static void test_run_to_end(void)
{
	mcd_run r;
	CHECK(mcd_run_init(&r));
	mcd_run_config(&r, BASE "[camera a]\ndriver = faulty\ndevice = A\nend_after = 20\n"
				"[camera b]\ndriver = faulty\ndevice = B\nformat = mjpeg\nend_after = 20\n");
	const char *const args[] = {"--print", "--exit-at-end", NULL};
	CHECK(mcd_run_start(&r, args, NULL));
	int rc = mcd_run_wait_exit(&r, 20000);
	CHECK_MSG(rc == 0, "exit %d", rc);
	char *out = mcd_read_file(r.out);
	int frames = mcd_count(out, "frame "), pairs = mcd_count(out, "cams 2/2");
	CHECK_MSG(frames >= 18 && frames <= 21, "%d frame lines", frames);
	CHECK_MSG(pairs >= 18, "%d complete frame sets of %d", pairs, frames);
	free(out);
	CHECK(r.notes && strstr(r.notes, "READY=1"));
	CHECK(r.notes && strstr(r.notes, "STATUS="));
	CHECK(r.notes && strstr(r.notes, "STOPPING=1"));
	CHECK(mcd_run_wait_log(&r, "every stream has ended; exiting", 0));
	CHECK(access(r.sock, F_OK) != 0); /* removed on the way out */
	if (mc_test_failures)
		mcd_run_dump(&r, "run to end");
	mcd_run_cleanup(&r);
}

/* A folder of 6 frames whose third has another size, played once: that
 * frame is dropped and counted, the other 5 are delivered, and mocapd
 * exits at the end (issue 20, defect 5: the camera was reopened, which
 * restarted the folder at its first frame, for ever). */
static void test_frame_of_another_size(void)
{
	mcd_run r;
	CHECK(mcd_run_init(&r));
	char dir[sizeof(r.dir) + 16], path[sizeof(dir) + 32];
	snprintf(dir, sizeof(dir), "%s/frames", r.dir);
	CHECK(mkdir(dir, 0755) == 0);
	/* PNG, which the driver decodes (and so checks) itself; an MJPEG
	 * frame of another size is the host's to drop (frame_problem). */
	mc_err err;
	static uint8_t rgb[64 * 48 * 3];
	for (int i = 0; i < 6; i++) {
		mc_canvas im = {rgb, i == 2 ? 32 : 64, i == 2 ? 24 : 48};
		memset(rgb, 40 * i, sizeof(rgb));
		snprintf(path, sizeof(path), "%s/%05d.png", dir, i);
		CHECK_MSG(mc_draw_write_png(path, &im, &err) == 0, "%s", err.msg);
	}
	char text[4 * PATH_MAX];
	snprintf(text, sizeof(text),
		 "[daemon]\nplugin_dir = %s/drivers\n[socket]\npath = @SOCK@\n[tracker]\nenabled = false\n"
		 "[camera a]\ndriver = files\npath = %s\nrate = 30\n",
		 mcd_build_dir, dir);
	mcd_run_config(&r, text);
	const char *const args[] = {"--print", "--exit-at-end", NULL};
	CHECK(mcd_run_start(&r, args, NULL));
	int rc = mcd_run_wait_exit(&r, 20000);
	CHECK_MSG(rc == 0, "exit %d (a frame of another size must not restart the folder)", rc);
	char *out = mcd_read_file(r.out);
	int frames = out ? mcd_count(out, "frame ") : -1;
	CHECK_MSG(frames == 5, "%d frame lines, expected the 5 of the stream's size", frames);
	free(out);
	CHECK(mcd_run_wait_log(&r, "frame dropped (files: '", 0) && mcd_run_wait_log(&r, "is 32x24, the stream is 64x48", 0));
	CHECK(!mcd_run_wait_log(&r, "reopening", 0));
	if (mc_test_failures)
		mcd_run_dump(&r, "frame of another size");
	for (int i = 0; i < 6; i++) {
		snprintf(path, sizeof(path), "%s/%05d.png", dir, i);
		unlink(path);
	}
	rmdir(dir);
	mcd_run_cleanup(&r);
}

/* A driver open() that fails for a reason that will not change (a bad
 * key value, an empty folder, a missing BVH) gives the camera up at once,
 * naming the config line, instead of reopening it for ever (issue 20,
 * defect 4). */
/* mocapd --check on one files camera of the demo clip with `key_line`
 * (line 10) added; returns its exit status. */
static int check_files_camera(mcd_run *r, const char *key_line)
{
	char text[2 * PATH_MAX + 256];
	snprintf(text, sizeof(text),
		 "[daemon]\nplugin_dir = %s/drivers\n[socket]\npath = @SOCK@\n[tracker]\nenabled = false\n"
		 "[camera a]\ndriver = files\npath = %s/tests/data/ego_demo/left\n%s\n",
		 mcd_build_dir, repo_dir, key_line);
	mcd_run_config(r, text);
	const char *const check[] = {"--check", NULL};
	return mcd_run_start(r, check, NULL) ? mcd_run_wait_exit(r, 10000) : -1;
}

static void test_permanent_open_errors(void)
{
	mcd_run r;
	CHECK(mcd_run_init(&r));
	char empty[sizeof(r.dir) + 16];
	snprintf(empty, sizeof(empty), "%s/empty", r.dir);
	CHECK(mkdir(empty, 0755) == 0);
	char text[4 * PATH_MAX];
	snprintf(text, sizeof(text),
		 "[daemon]\nplugin_dir = %s/drivers\nreopen_initial_ms = 50\nreopen_max_ms = 100\n"
		 "[socket]\npath = @SOCK@\n[tracker]\nenabled = false\n"
		 "[camera rate]\ndriver = files\npath = %s\nrate = -5\n"
		 "[camera loop]\ndriver = files\npath = %s\nloop = maybe\n"
		 "[camera sim]\ndriver = sim\nbvh = %s\n",
		 mcd_build_dir, empty, empty, empty);
	mcd_run_config(&r, text);
	CHECK(mcd_run_start(&r, print_args, NULL));
	CHECK(mcd_run_wait_log(&r, "[camera rate]: open: files: config key 'rate'", 10000));
	CHECK(mcd_run_wait_log(&r, "[camera loop]: open: files: config key 'loop'", 10000));
	CHECK(mcd_run_wait_log(&r, "[camera sim]: open: sim: ", 10000));
	mcd_sleep_ms(500); /* ten backoff periods */
	char want[PATH_MAX + 64];
	/* the line of the key the driver names, not only the section's */
	snprintf(want, sizeof(want), "%s:12: [camera rate]: open: files: config key 'rate'", r.conf);
	CHECK_MSG(mcd_run_wait_log(&r, want, 0), "the log has no '%s'", want);
	CHECK_MSG(mcd_run_count(r.log, "giving up on this camera") == 3, "%d cameras given up",
		  mcd_run_count(r.log, "giving up on this camera"));
	CHECK_MSG(mcd_run_count(r.log, "reopening") == 0, "a permanent error was retried");
	/* mocapctl says what the log says: failed, not error (being reopened) */
	char cmd[PATH_MAX + 300], out[4096] = "";
	snprintf(cmd, sizeof(cmd), "%s/bin/mocapctl --socket %s status 2>&1", mcd_build_dir, r.sock);
	mcd_sleep_ms(1100); /* a status snapshot after the failures */
	int rc = mc_test_run(cmd, out, sizeof(out));
	CHECK_MSG(rc == 0 && mcd_count(out, " failed ") == 3 && !strstr(out, " error "), "mocapctl status: %d\n%s", rc,
		  out);
	mcd_run_terminate(&r, 10000, "permanent open errors");
	if (mc_test_failures > r.failures_at_init)
		mcd_run_dump(&r, "permanent open errors");

	/* --check asks each driver to check its keys, opening nothing: the
	 * same bad value on its line, then a key no driver reads. */
	const char *const check[] = {"--check", NULL};
	CHECK(mcd_run_start(&r, check, NULL));
	CHECK(mcd_run_wait_exit(&r, 10000) == 1);
	snprintf(want, sizeof(want), "%s:12: [camera rate] files: config key 'rate': expected a number", r.conf);
	CHECK_MSG(mcd_run_wait_log(&r, want, 0), "--check: the log has no '%s'", want);
	CHECK(check_files_camera(&r, "lopo = true") == 1);
	snprintf(want, sizeof(want), "%s:10: [camera a] lopo: unknown key (the files driver does not read it; did you mean 'loop'?)",
		 r.conf);
	CHECK_MSG(mcd_run_wait_log(&r, want, 0), "--check: the log has no '%s'", want);
	/* every camera's error, not only the first (issue 31 item 6) */
	CHECK(check_files_camera(&r, "lopo = true\n[camera b]\ndriver = files\npath = /nonexistent\nrat = 3") == 1);
	CHECK_MSG(mcd_run_wait_log(&r, "[camera a] lopo: unknown key", 0) &&
			  mcd_run_wait_log(&r, "[camera b] files: config key 'path': '/nonexistent'", 0) &&
			  mcd_run_wait_log(&r, ": 2 errors", 0),
		  "--check did not list both cameras' errors");
	CHECK(check_files_camera(&r, "loop = true") == 0); /* and a good config passes */
	rmdir(empty);
	mcd_run_cleanup(&r);
}

static void test_config_error(void)
{
	mcd_run r;
	CHECK(mcd_run_init(&r));
	mcd_run_config(&r, BASE "iteratons = 5\n" TWO_CAMS);
	CHECK(mcd_run_start(&r, NULL, NULL));
	CHECK(mcd_run_wait_exit(&r, 10000) == 1);
	char want[256];
	snprintf(want, sizeof(want), "mocapd: error: %s:9: [tracker] iteratons: unknown key", r.conf);
	CHECK_MSG(mcd_run_wait_log(&r, want, 0), "no '%s'", want);
	CHECK(r.notes && strstr(r.notes, "STATUS=") && strstr(r.notes, "iteratons: unknown key"));
	mcd_run_cleanup(&r);

	/* --check reports the same without starting anything */
	CHECK(mcd_run_init(&r));
	mcd_run_config(&r, BASE TWO_CAMS);
	const char *const check[] = {"--check", NULL};
	CHECK(mcd_run_start(&r, check, NULL));
	CHECK(mcd_run_wait_exit(&r, 10000) == 0);
	mcd_run_config(&r, BASE "[camera a]\ndriver = nosuch\n");
	CHECK(mcd_run_start(&r, check, NULL));
	CHECK(mcd_run_wait_exit(&r, 10000) == 1);
	CHECK(mcd_run_wait_log(&r, ":10: [camera a] driver: driver 'nosuch': no mocap-driver-nosuch.so in", 0));
	mcd_run_cleanup(&r);
}

static void test_refused_plugin_dir(void)
{
	mcd_run r;
	CHECK(mcd_run_init(&r));
	/* A plugin directory anybody can write to. */
	char dir[200], cmd[700];
	snprintf(dir, sizeof(dir), "%s/plugins", r.dir);
	CHECK(mkdir(dir, 0777) == 0);
	chmod(dir, 0777);
	snprintf(cmd, sizeof(cmd), "cp %.300s/mocap-driver-faulty.so %.200s/", mcd_faulty_dir, dir);
	CHECK(system(cmd) == 0);
	char conf[1024];
	snprintf(conf, sizeof(conf),
		 "[daemon]\nplugin_dir = plugins\n[socket]\npath = @SOCK@\n[tracker]\nenabled = false\n" TWO_CAMS);
	mcd_run_config(&r, conf);
	CHECK(mcd_run_start(&r, NULL, NULL));
	CHECK(mcd_run_wait_exit(&r, 10000) == 1);
	CHECK(mcd_run_wait_log(&r, "plugins: directory writable by others (mode 0777); refused", 0));
	snprintf(cmd, sizeof(cmd), "rm -rf %s", dir);
	CHECK(system(cmd) == 0);
	mcd_run_cleanup(&r);
}

static void test_sigterm(void)
{
	mcd_run r;
	CHECK(mcd_run_init(&r));
	mcd_run_config(&r, BASE TWO_CAMS);
	CHECK(mcd_run_start(&r, print_args, NULL));
	CHECK(mcd_run_wait_notify(&r, "READY=1", 10000));
	CHECK(mcd_can_connect(r.sock));
	CHECK(mcd_run_wait_log(&r, "camera b: opened", 5000));
	mcd_sleep_ms(300);
	uint64_t t0 = mcd_now_ms();
	mcd_run_terminate(&r, 10000, "sigterm");
	CHECK_MSG(mcd_now_ms() - t0 < 3000, "took %llu ms to stop", (unsigned long long)(mcd_now_ms() - t0));
	CHECK(mcd_run_wait_log(&r, "Terminated: shutting down", 0));
	CHECK(mcd_run_wait_log(&r, "mocapd: info: stopped", 0));
	CHECK(access(r.sock, F_OK) != 0);
	CHECK(mcd_run_count(r.out, "cams 2/2") > 3);
	if (mc_test_failures)
		mcd_run_dump(&r, "sigterm");
	mcd_run_cleanup(&r);
}

/* mocapctl, where built, sees the daemon's status and reloads it. */
static void test_mocapctl(void)
{
	char ctl[PATH_MAX + 32];
	snprintf(ctl, sizeof(ctl), "%s/bin/mocapctl", mcd_build_dir);
	if (access(ctl, X_OK) != 0) {
		printf("mocapctl is not built; client checks skipped\n");
		return;
	}
	mcd_run r;
	CHECK(mcd_run_init(&r));
	mcd_run_config(&r, BASE TWO_CAMS);
	CHECK(mcd_run_start(&r, NULL, NULL));
	CHECK(mcd_run_wait_notify(&r, "READY=1", 10000));
	CHECK(mcd_run_wait_notify(&r, "b: streaming", 5000));
	mcd_sleep_ms(1200); /* a status snapshot with rates */
	char cmd[8400], out[4096] = "";
	snprintf(cmd, sizeof(cmd), "%s --socket %s status 2>&1", ctl, r.sock);
	int rc = mc_test_run(cmd, out, sizeof(out));
	CHECK_MSG(rc == 0, "mocapctl status: %d\n%s", rc, out);
	CHECK_MSG(strstr(out, "cameras:    2") && strstr(out, "64x48"), "%s", out);
	snprintf(cmd, sizeof(cmd), "%s --socket %s status --json 2>&1", ctl, r.sock);
	rc = mc_test_run(cmd, out, sizeof(out));
	json_error_t jerr;
	json_t *st = json_loads(out, 0, &jerr);
	json_t *cams = json_object_get(st, "cameras");
	CHECK_MSG(rc == 0 && json_is_array(cams) && json_array_size(cams) == 2, "status --json: %s (%s)", out, jerr.text);
	CHECK(json_integer_value(json_object_get(json_array_get(cams, 1), "width")) == 64);
	CHECK(json_is_string(json_object_get(st, "tracker_state")) && json_is_object(json_object_get(st, "detector")));
	json_decref(st);
	snprintf(cmd, sizeof(cmd), "%s --socket %s reload 2>&1", ctl, r.sock);
	rc = mc_test_run(cmd, out, sizeof(out));
	CHECK_MSG(rc == 0 && strstr(out, "nothing changed"), "reload: %d %s", rc, out);
	CHECK(mcd_run_wait_log(&r, "reload requested by pid", 3000));
	CHECK(mcd_run_wait_log(&r, "applied", 3000));
	/* the reply names what was applied and what needs a restart, and
	 * the exit status tells the two apart */
	mcd_run_config(&r, BASE_WITH("log_level = debug\nstatus_interval_s = 2\n") TWO_CAMS);
	rc = mc_test_run(cmd, out, sizeof(out));
	CHECK_MSG(rc == 0 && strstr(out, "applied: [daemon] log_level") && !strstr(out, "restart"), "reload: %d %s", rc, out);
	mcd_run_config(&r, BASE TWO_CAMS "[camera c]\ndriver = faulty\ndevice = C\n");
	rc = mc_test_run(cmd, out, sizeof(out));
	CHECK_MSG(rc == 7 && strstr(out, "needs a restart: cameras"), "reload: %d %s", rc, out);
	mcd_run_stop(&r, 10000, "mocapctl");
}

/* Under journald (stderr is the stream named by $JOURNAL_STREAM) lines
 * carry sd-daemon priority prefixes instead of level words. */
static void test_journal_prefixes(void)
{
	mcd_run r;
	CHECK(mcd_run_init(&r));
	mcd_run_config(&r, BASE "[camera a]\ndriver = faulty\ndevice = A\nend_after = 5\n"
				"[camera b]\ndriver = nosuch\n");
	/* The log file exists before the daemon opens it (O_TRUNC keeps the
	 * inode), so its device:inode can be named in advance. */
	FILE *f = fopen(r.log, "w");
	CHECK(f != NULL);
	if (f)
		fclose(f);
	struct stat st;
	CHECK(stat(r.log, &st) == 0);
	char env_js[96];
	snprintf(env_js, sizeof(env_js), "JOURNAL_STREAM=%llu:%llu", (unsigned long long)st.st_dev,
		 (unsigned long long)st.st_ino);
	const char *const env[] = {env_js, NULL};
	CHECK(mcd_run_start(&r, NULL, env));
	CHECK(mcd_run_wait_exit(&r, 10000) == 1);
	CHECK(mcd_run_wait_log(&r, "<6>mocapd ", 0) && mcd_run_wait_log(&r, " starting with ", 0));
	CHECK(mcd_run_wait_log(&r, "<3>", 0));
	CHECK(!mcd_run_wait_log(&r, "mocapd: info:", 0));
	if (mc_test_failures)
		mcd_run_dump(&r, "journal");
	mcd_run_cleanup(&r);
}

static void test_sigkill_restart(void)
{
	mcd_run r;
	CHECK(mcd_run_init(&r));
	mcd_run_config(&r, BASE TWO_CAMS);
	CHECK(mcd_run_start(&r, NULL, NULL));
	CHECK(mcd_run_wait_notify(&r, "READY=1", 10000));
	mcd_run_signal(&r, SIGKILL);
	CHECK(mcd_run_wait_exit(&r, 5000) == 128 + SIGKILL);
	struct stat st;
	CHECK(stat(r.sock, &st) == 0 && S_ISSOCK(st.st_mode)); /* left behind, stale */
	CHECK(!mcd_can_connect(r.sock));
	/* A new daemon starts right away, on the same socket path. */
	CHECK(mcd_run_start(&r, NULL, NULL));
	CHECK_MSG(mcd_run_wait_notify(&r, "READY=1", 10000), "no READY=1 after a restart");
	CHECK(mcd_can_connect(r.sock));
	CHECK(mcd_run_alive(&r));

	/* A second daemon on the same socket while the first one lives is
	 * refused, and leaves the first one's socket alone. */
	mcd_run second;
	CHECK(mcd_run_init(&second));
	char conf[2048];
	snprintf(conf, sizeof(conf),
		 "[daemon]\nplugin_dir = @FAULTY@\n[socket]\npath = %s\n[tracker]\nenabled = false\n" TWO_CAMS, r.sock);
	mcd_run_config(&second, conf);
	CHECK(mcd_run_start(&second, NULL, NULL));
	CHECK(mcd_run_wait_exit(&second, 10000) == 1);
	CHECK(mcd_run_wait_log(&second, "another mocapd", 0) || mcd_run_wait_log(&second, "listening", 0));
	CHECK(mcd_can_connect(r.sock));
	mcd_run_cleanup(&second);

	mcd_run_stop(&r, 10000, "sigkill");
}

static void test_sighup(void)
{
	mcd_run r;
	CHECK(mcd_run_init(&r));
	mcd_run_config(&r, BASE TWO_CAMS);
	CHECK(mcd_run_start(&r, NULL, NULL));
	CHECK(mcd_run_wait_notify(&r, "READY=1", 10000));
	CHECK(mcd_run_wait_log(&r, "camera b: opened", 5000));
	/* debug logging and a camera change that needs a restart */
	mcd_run_config(&r, BASE_WITH("log_level = debug\n") "[camera a]\ndriver = faulty\ndevice = A\nfps = 25\n"
			   "[camera b]\ndriver = faulty\ndevice = B\nformat = mjpeg\n");
	mcd_run_signal(&r, SIGHUP);
	CHECK(mcd_run_wait_log(&r, "applied (log level debug)", 5000));
	CHECK(mcd_run_wait_log(&r, "reload: cameras changed; that takes a restart", 0));
	CHECK(mcd_run_wait_notify(&r, "RELOADING=1", 2000));
	/* a broken config: the running one stays */
	mcd_run_config(&r, BASE "[camera a]\ndriver = faulty\nring_slots = one\n");
	mcd_run_signal(&r, SIGHUP);
	CHECK(mcd_run_wait_log(&r, "ring_slots: expected an integer from 2 to 1024, got 'one'; keeping the running config",
			       5000));
	mcd_sleep_ms(200);
	CHECK(mcd_run_alive(&r));
	mcd_run_stop(&r, 10000, "sighup");
}

static void test_socket_activation(void)
{
	mcd_run r;
	CHECK(mcd_run_init(&r));
	mcd_run_config(&r, BASE TWO_CAMS);
	int fd = socket(AF_UNIX, SOCK_SEQPACKET, 0);
	struct sockaddr_un a = {.sun_family = AF_UNIX};
	snprintf(a.sun_path, sizeof(a.sun_path), "%.100s", r.sock);
	CHECK(fd >= 0 && bind(fd, (struct sockaddr *)&a, sizeof(a)) == 0 && listen(fd, 8) == 0);
	CHECK(mcd_run_start_fd(&r, NULL, NULL, fd));
	close(fd);
	CHECK(mcd_run_wait_notify(&r, "READY=1", 10000));
	CHECK(mcd_run_wait_log(&r, "(from systemd)", 0));
	CHECK(mcd_can_connect(r.sock));
	mcd_run_terminate(&r, 10000, "socket activation");
	/* The socket belongs to systemd: it stays. */
	struct stat st;
	CHECK(stat(r.sock, &st) == 0 && S_ISSOCK(st.st_mode));

	/* A passed socket of the wrong type is refused with a clear message. */
	fd = socket(AF_UNIX, SOCK_STREAM, 0);
	unlink(r.sock);
	CHECK(fd >= 0 && bind(fd, (struct sockaddr *)&a, sizeof(a)) == 0 && listen(fd, 8) == 0);
	CHECK(mcd_run_start_fd(&r, NULL, NULL, fd));
	close(fd);
	CHECK(mcd_run_wait_exit(&r, 10000) == 1);
	CHECK(mcd_run_wait_log(&r, "not a listening SOCK_SEQPACKET Unix socket", 0));
	if (mc_test_failures)
		mcd_run_dump(&r, "socket activation");
	mcd_run_cleanup(&r);
}

/* --exit-at-end when no camera can ever deliver (issue 34): one empty
 * folder, one whose only frame does not decode.  Both cameras fail for
 * good; mocapd used to wait forever for a stream to end. */
static void test_exit_at_end_all_failed(void)
{
	mcd_run r;
	CHECK(mcd_run_init(&r));
	char empty[sizeof(r.dir) + 16], bad[sizeof(r.dir) + 16], junk[sizeof(bad) + 16];
	snprintf(empty, sizeof(empty), "%s/empty", r.dir);
	snprintf(bad, sizeof(bad), "%s/bad", r.dir);
	snprintf(junk, sizeof(junk), "%s/000000.jpg", bad);
	CHECK(mkdir(empty, 0755) == 0 && mkdir(bad, 0755) == 0);
	FILE *f = fopen(junk, "w");
	CHECK(f != NULL);
	if (f) {
		fputs("not a JPEG image", f);
		fclose(f);
	}
	char text[4 * PATH_MAX];
	snprintf(text, sizeof(text),
		 "[daemon]\nplugin_dir = %s/drivers\nreopen_initial_ms = 50\nreopen_max_ms = 100\n"
		 "[socket]\npath = @SOCK@\n[tracker]\nenabled = false\n"
		 "[camera a]\ndriver = files\npath = %s\n[camera b]\ndriver = files\npath = %s\n",
		 mcd_build_dir, empty, bad);
	mcd_run_config(&r, text);
	const char *const args[] = {"--exit-at-end", NULL};
	CHECK(mcd_run_start(&r, args, NULL));
	int rc = mcd_run_wait_exit(&r, 15000);
	printf("every camera failed, --exit-at-end: exit %d\n", rc);
	CHECK_MSG(rc == 1, "mocapd did not exit with status 1 in 15 s (got %d)", rc);
	CHECK_MSG(mcd_run_wait_log(&r, "every camera has failed for good", 0), "the log does not say why");
	if (mc_test_failures)
		mcd_run_dump(&r, "exit at end, all failed");
	unlink(junk);
	rmdir(bad);
	rmdir(empty);
	mcd_run_cleanup(&r);
}

int main(void)
{
	if (!mcd_find_build())
		TEST_SKIP("mocapd is not built");
	if (!getcwd(repo_dir, sizeof(repo_dir)))
		TEST_SKIP("no working directory");
	test_run_to_end();
	test_frame_of_another_size();
	test_permanent_open_errors();
	test_exit_at_end_all_failed();
	test_config_error();
	test_refused_plugin_dir();
	test_sigterm();
	test_sigkill_restart();
	test_sighup();
	test_journal_prefixes();
	test_mocapctl();
	test_socket_activation();
	return mc_test_finish("test_daemon_run");
}
