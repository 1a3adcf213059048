/* Runs mocapd as a child process for the integration tests (C and C++).
 *
 * Each run gets a scratch directory under /tmp with its config, the
 * daemon's stdout and stderr, its socket, and a datagram socket standing in
 * for systemd's $NOTIFY_SOCKET, so that READY=1, STATUS=, WATCHDOG=1 and
 * friends can be checked.  mocapd and the fault driver are found next to
 * the test program: <build>/bin/mocapd and <build>/tests/faulty/. */
#ifndef MCD_TEST_HARNESS_H
#define MCD_TEST_HARNESS_H

#include "base/mc_time.h"
#include "../test_util.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <poll.h>
#include <signal.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

typedef struct {
	char dir[64];
	char conf[128], log[128], out[128], sock[128], notify[128];
	pid_t pid;
	int status; /* wait status once exited */
	int notify_fd;
	char *notes; /* every notify message received, each ending in "\n--\n" */
	size_t notes_len, notes_cap;
	int failures_at_init; /* mc_test_failures when the run was made: mcd_run_stop dumps on more */
} mcd_run;

static char mcd_build_dir[PATH_MAX];
static char mcd_mocapd[PATH_MAX + 32];
static char mcd_faulty_dir[PATH_MAX + 32];

static inline uint64_t mcd_now_ms(void)
{
	return mc_now_ns() / MC_NS_PER_MS;
}

static inline void mcd_sleep_ms(int ms)
{
	mc_sleep_until_ns(mc_now_ns() + (uint64_t)ms * MC_NS_PER_MS);
}

/* Finds the build folder `up` levels above this test program (2 for
 * <build>/tests/TEST, 3 for <build>/detect/tests/TEST), mocapd and the
 * fault driver in it; false (with a reason printed) if they are not built. */
static inline bool mcd_find_build_up(int up)
{
	if (!mc_test_build_dir(up, mcd_build_dir, sizeof(mcd_build_dir)))
		return false;
	snprintf(mcd_mocapd, sizeof(mcd_mocapd), "%s/bin/mocapd", mcd_build_dir);
	snprintf(mcd_faulty_dir, sizeof(mcd_faulty_dir), "%s/tests/faulty", mcd_build_dir);
	if (access(mcd_mocapd, X_OK) != 0) {
		printf("mocapd is not built (%s)\n", mcd_mocapd);
		return false;
	}
	return true;
}

static inline bool mcd_find_build(void)
{
	return mcd_find_build_up(2);
}

/* Runs prog with args (NULL-terminated, without argv[0]), stdout and
 * stderr into the file out; the child's pid, or -1. */
static inline pid_t mcd_spawn(const char *prog, const char *const *args, const char *out)
{
	pid_t pid = fork();
	if (pid == 0) {
		int fd = open(out, O_WRONLY | O_CREAT | O_TRUNC, 0644);
		if (fd < 0)
			_exit(126);
		dup2(fd, 1);
		dup2(fd, 2);
		const char *argv[32] = {prog};
		int n = 1;
		for (int i = 0; args[i] && n < 31; i++)
			argv[n++] = args[i];
		argv[n] = NULL;
		execv(prog, (char *const *)argv);
		_exit(127);
	}
	return pid;
}

/* Waits for pid; its exit status, 128+signal, or -1 after timeout_ms (then
 * it is killed). */
static inline int mcd_wait_pid(pid_t pid, int timeout_ms)
{
	uint64_t end = mcd_now_ms() + (uint64_t)timeout_ms;
	int st;
	for (;;) {
		pid_t w = waitpid(pid, &st, WNOHANG);
		if (w == pid)
			return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
		if (mcd_now_ms() >= end) {
			kill(pid, SIGKILL);
			waitpid(pid, &st, 0);
			return -1;
		}
		mcd_sleep_ms(10);
	}
}

static inline char *mcd_read_file(const char *path)
{
	FILE *f = fopen(path, "rb");
	if (!f)
		return (char *)calloc(1, 1);
	fseek(f, 0, SEEK_END);
	long n = ftell(f);
	fseek(f, 0, SEEK_SET);
	char *s = (char *)calloc(1, (size_t)(n > 0 ? n : 0) + 1);
	if (s && n > 0 && fread(s, 1, (size_t)n, f) != (size_t)n)
		s[0] = 0;
	fclose(f);
	return s;
}

static inline int mcd_count(const char *hay, const char *needle)
{
	int n = 0;
	for (const char *p = hay; (p = strstr(p, needle)); p += strlen(needle))
		n++;
	return n;
}

static inline bool mcd_run_init(mcd_run *r)
{
	memset(r, 0, sizeof(*r));
	r->failures_at_init = mc_test_failures;
	r->pid = -1;
	r->notify_fd = -1;
	snprintf(r->dir, sizeof(r->dir), "/tmp/mocapd-test-XXXXXX");
	if (!mkdtemp(r->dir))
		return false;
	chmod(r->dir, 0755);
	snprintf(r->conf, sizeof(r->conf), "%s/t.conf", r->dir);
	snprintf(r->log, sizeof(r->log), "%s/stderr.txt", r->dir);
	snprintf(r->out, sizeof(r->out), "%s/stdout.txt", r->dir);
	snprintf(r->sock, sizeof(r->sock), "%s/mocapd.sock", r->dir);
	snprintf(r->notify, sizeof(r->notify), "%s/notify", r->dir);
	r->notify_fd = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
	struct sockaddr_un a;
	memset(&a, 0, sizeof(a));
	a.sun_family = AF_UNIX;
	snprintf(a.sun_path, sizeof(a.sun_path), "%.100s", r->notify);
	return r->notify_fd >= 0 && bind(r->notify_fd, (struct sockaddr *)&a, sizeof(a)) == 0;
}

/* Writes the config; "@FAULTY@" and "@SOCK@" in the text become the fault
 * driver's directory and the run's socket path. */
static inline void mcd_run_config(mcd_run *r, const char *text)
{
	FILE *f = fopen(r->conf, "w");
	if (!f)
		return;
	for (const char *p = text; *p;) {
		if (strncmp(p, "@FAULTY@", 8) == 0) {
			fputs(mcd_faulty_dir, f);
			p += 8;
		} else if (strncmp(p, "@SOCK@", 6) == 0) {
			fputs(r->sock, f);
			p += 6;
		} else
			fputc(*p++, f);
	}
	fclose(f);
}

/* Starts mocapd -c <conf> plus args (NULL-terminated).  env: extra
 * "NAME=value" strings (NULL-terminated, may be NULL).  listen_fd >= 0 is
 * passed as systemd would pass a socket (fd 3, LISTEN_FDS, LISTEN_PID). */
static inline bool mcd_run_start_fd(mcd_run *r, const char *const *args, const char *const *env, int listen_fd)
{
	r->notes_len = 0;
	if (r->notes)
		r->notes[0] = 0;
	pid_t pid = fork();
	if (pid < 0)
		return false;
	if (pid == 0) {
		int out = open(r->out, O_WRONLY | O_CREAT | O_TRUNC, 0644);
		int err = open(r->log, O_WRONLY | O_CREAT | O_TRUNC, 0644);
		if (out < 0 || err < 0)
			_exit(126);
		dup2(out, 1);
		dup2(err, 2);
		setenv("NOTIFY_SOCKET", r->notify, 1);
		unsetenv("JOURNAL_STREAM");
		unsetenv("LISTEN_FDS");
		unsetenv("WATCHDOG_USEC");
		for (int i = 0; env && env[i]; i++)
			putenv((char *)env[i]);
		if (listen_fd >= 0) {
			if (listen_fd != 3) {
				dup2(listen_fd, 3);
				close(listen_fd);
			} else
				fcntl(3, F_SETFD, 0);
			char pidbuf[32];
			snprintf(pidbuf, sizeof(pidbuf), "%d", (int)getpid());
			setenv("LISTEN_PID", pidbuf, 1);
			setenv("LISTEN_FDS", "1", 1);
		}
		const char *argv[32] = {mcd_mocapd, "-c", r->conf};
		int n = 3;
		for (int i = 0; args && args[i] && n < 31; i++)
			argv[n++] = args[i];
		argv[n] = NULL;
		execv(mcd_mocapd, (char *const *)argv);
		_exit(127);
	}
	r->pid = pid;
	return true;
}

static inline bool mcd_run_start(mcd_run *r, const char *const *args, const char *const *env)
{
	return mcd_run_start_fd(r, args, env, -1);
}

static inline void mcd_run_read_notify(mcd_run *r)
{
	char buf[4096];
	ssize_t n;
	while ((n = recv(r->notify_fd, buf, sizeof(buf) - 1, 0)) > 0) {
		if (r->notes_len + (size_t)n + 8 > r->notes_cap) {
			size_t cap = (r->notes_len + (size_t)n + 8) * 2;
			char *grown = (char *)realloc(r->notes, cap);
			if (!grown)
				return;
			r->notes = grown;
			r->notes_cap = cap;
		}
		memcpy(r->notes + r->notes_len, buf, (size_t)n);
		r->notes_len += (size_t)n;
		memcpy(r->notes + r->notes_len, "\n--\n", 5);
		r->notes_len += 4;
	}
}

static inline bool mcd_run_alive(mcd_run *r)
{
	if (r->pid <= 0)
		return false;
	pid_t w = waitpid(r->pid, &r->status, WNOHANG);
	if (w == r->pid) {
		r->pid = -1;
		return false;
	}
	return true;
}

/* Waits until the daemon's stderr contains needle. */
static inline bool mcd_run_wait_log(mcd_run *r, const char *needle, int timeout_ms)
{
	uint64_t end = mcd_now_ms() + (uint64_t)timeout_ms;
	for (;;) {
		/* sd_notify blocks once the socket's queue is full (10
		 * datagrams: 5 s of STATUS at status_interval_s = 0.5), and with
		 * it the daemon's main loop: read what came, as systemd does */
		mcd_run_read_notify(r);
		char *log = mcd_read_file(r->log);
		bool found = log && strstr(log, needle);
		free(log);
		if (found)
			return true;
		if (mcd_now_ms() >= end)
			return false;
		mcd_sleep_ms(20);
	}
}

/* Counts occurrences of needle in the daemon's stderr (or stdout). */
static inline int mcd_run_count(const char *path, const char *needle)
{
	char *s = mcd_read_file(path);
	int n = s ? mcd_count(s, needle) : 0;
	free(s);
	return n;
}

/* Waits until a notify message containing needle arrived. */
static inline bool mcd_run_wait_notify(mcd_run *r, const char *needle, int timeout_ms)
{
	uint64_t end = mcd_now_ms() + (uint64_t)timeout_ms;
	for (;;) {
		mcd_run_read_notify(r);
		if (r->notes && strstr(r->notes, needle))
			return true;
		if (mcd_now_ms() >= end)
			return false;
		struct pollfd p = {r->notify_fd, POLLIN, 0};
		poll(&p, 1, 20);
	}
}

/* Waits for the daemon to exit; returns its exit code, 128+signal, or -1
 * on timeout. */
static inline int mcd_run_wait_exit(mcd_run *r, int timeout_ms)
{
	uint64_t end = mcd_now_ms() + (uint64_t)timeout_ms;
	while (r->pid > 0) {
		pid_t w = waitpid(r->pid, &r->status, WNOHANG);
		if (w == r->pid) {
			r->pid = -1;
			break;
		}
		if (mcd_now_ms() >= end)
			return -1;
		mcd_run_read_notify(r); /* a blocked sd_notify would hold the shutdown */
		mcd_sleep_ms(10);
	}
	mcd_run_read_notify(r);
	if (WIFEXITED(r->status))
		return WEXITSTATUS(r->status);
	if (WIFSIGNALED(r->status))
		return 128 + WTERMSIG(r->status);
	return -1;
}

static inline void mcd_run_signal(mcd_run *r, int sig)
{
	if (r->pid > 0)
		kill(r->pid, sig);
}

/* Prints the daemon's stderr (for a failing check). */
static inline void mcd_run_dump(mcd_run *r, const char *why)
{
	char *log = mcd_read_file(r->log);
	fprintf(stderr, "---- %s: mocapd stderr (%s) ----\n%s---- end ----\n", why, r->log, log ? log : "");
	free(log);
}

static inline void mcd_run_cleanup(mcd_run *r)
{
	if (r->pid > 0) {
		kill(r->pid, SIGKILL);
		waitpid(r->pid, &r->status, 0);
		r->pid = -1;
	}
	/* Idempotent: a run cleaned up by a failed start may be again. */
	if (r->notify_fd >= 0)
		close(r->notify_fd);
	r->notify_fd = -1;
	free(r->notes);
	r->notes = NULL;
	r->notes_len = r->notes_cap = 0;
	const char *names[] = {"t.conf", "stderr.txt", "stdout.txt", "mocapd.sock", "notify", "other.sock"};
	for (size_t i = 0; i < sizeof(names) / sizeof(names[0]); i++) {
		char p[256];
		snprintf(p, sizeof(p), "%s/%s", r->dir, names[i]);
		unlink(p);
	}
	rmdir(r->dir);
}

/* Sends SIGTERM and waits up to timeout_ms for the daemon to exit; checks
 * that it exited 0 (why names the run in the message).  Its exit code,
 * 128+signal, or -1 if it is still running. */
static inline int mcd_run_terminate(mcd_run *r, int timeout_ms, const char *why)
{
	mcd_run_signal(r, SIGTERM);
	int rc = mcd_run_wait_exit(r, timeout_ms);
	CHECK_MSG(rc == 0, "%s: mocapd exited %d after SIGTERM (-1: still running after %d ms)", why, rc, timeout_ms);
	return rc;
}

/* The end of a test's run: mcd_run_terminate, mocapd's stderr printed
 * under why if any check failed since mcd_run_init, and the run cleaned
 * up.  Returns what mcd_run_terminate did. */
static inline int mcd_run_stop(mcd_run *r, int timeout_ms, const char *why)
{
	int rc = mcd_run_terminate(r, timeout_ms, why);
	if (mc_test_failures > r->failures_at_init)
		mcd_run_dump(r, why);
	mcd_run_cleanup(r);
	return rc;
}

/* Starts mocapd with args (NULL-terminated) and waits up to 60 s for
 * READY=1.  On failure its output is dumped and the run cleaned up; the
 * test is skipped when the tracker has no usable OpenCL device here, and
 * otherwise a failed check is counted and false returned. */
static inline bool mcd_run_start_ready(mcd_run *r, const char *const *args)
{
	CHECK(mcd_run_start(r, args, NULL));
	if (mcd_run_wait_notify(r, "READY=1", 60000))
		return true;
	char *log = mcd_read_file(r->log);
	bool no_cl = log && strstr(log, "OpenCL") && strstr(log, "error");
	free(log);
	mcd_run_dump(r, "start");
	mcd_run_cleanup(r);
	if (no_cl)
		TEST_SKIP("the tracker cannot run here (no usable OpenCL device)");
	CHECK_MSG(false, "mocapd did not become ready");
	return false;
}

/* True if something accepts connections on a SOCK_SEQPACKET socket path. */
static inline bool mcd_can_connect(const char *path)
{
	int fd = socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
	struct sockaddr_un a;
	memset(&a, 0, sizeof(a));
	a.sun_family = AF_UNIX;
	snprintf(a.sun_path, sizeof(a.sun_path), "%.100s", path);
	bool ok = fd >= 0 && connect(fd, (struct sockaddr *)&a, sizeof(a)) == 0;
	if (fd >= 0)
		close(fd);
	return ok;
}

/* The config of the tests that run mocapd on the bundled clip: both
 * cameras of tests/data/ego_demo through the files driver, in a loop at
 * `rate` fps, tracked with the default body model, on the run's socket
 * (@SOCK@).  daemon_extra and camera_extra are lines added to [daemon] and
 * to each camera section ("" for none); tracker_extra the lines of
 * [tracker] after rig and model (NULL: init_joints from the clip's first
 * ground-truth frame); extra is appended (another section).  repo is the
 * repository root. */
static inline void mcd_demo_clip_config(char *buf, size_t cap, const char *repo, int rate, const char *daemon_extra,
					const char *camera_extra, const char *tracker_extra, const char *extra)
{
	char init[PATH_MAX + 64] = "";
	if (!tracker_extra) {
		snprintf(init, sizeof(init), "init_joints = %s/tests/data/ego_demo/gt.json\n", repo);
		tracker_extra = init;
	}
	snprintf(buf, cap,
		 "[daemon]\nplugin_dir = %s/drivers\n%s"
		 "[camera left]\ndriver = files\nrig_camera = left\nloop = true\nrate = %d\n%s"
		 "path = %s/tests/data/ego_demo/left\n"
		 "[camera right]\ndriver = files\nrig_camera = right\nloop = true\nrate = %d\n%s"
		 "path = %s/tests/data/ego_demo/right\n"
		 "[tracker]\nrig = %s/config/rigs/ego_stereo.json\nmodel = %s/config/models/default.json\n%s"
		 "[socket]\npath = @SOCK@\n%s",
		 mcd_build_dir, daemon_extra, rate, camera_extra, repo, rate, camera_extra, repo, repo, repo, tracker_extra,
		 extra);
}

/* Skips the test unless mocapd is built and the test runs from the
 * repository root (where the bundled clip is); repo gets that root. */
static inline void mcd_require_build_and_clip(char *repo, size_t cap)
{
	if (!mcd_find_build())
		TEST_SKIP("mocapd is not built");
	if (!getcwd(repo, cap) || access("tests/data/ego_demo/gt.json", R_OK) != 0)
		TEST_SKIP("run from the repository root (tests/data/ego_demo not found)");
}

/* The same, and the files driver built (the tests that play the clip). */
static inline void mcd_require_files_driver(char *repo, size_t cap)
{
	mcd_require_build_and_clip(repo, cap);
	char files[PATH_MAX + 64];
	snprintf(files, sizeof(files), "%s/drivers/mocap-driver-files.so", mcd_build_dir);
	if (access(files, R_OK) != 0)
		TEST_SKIP("the files driver is not built (%s)", files);
}

#endif
