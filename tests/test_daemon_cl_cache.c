/* The OpenCL (PoCL) kernel cache folder for a hand start (daemon/cl_cache.h,
 * issue 31 item 3): mocapd run as a user whose home is unusable (the
 * `mocapd` user's is /nonexistent) used to fail with "OpenCL: no device on
 * any platform" after --check said ok. */
#include "cl_cache.h"
#include "daemon/harness.h"

static char tmpdir[] = "/tmp/mocapd-clcache-XXXXXX";

static void clear_env(void)
{
	unsetenv("POCL_CACHE_DIR");
	unsetenv("XDG_CACHE_HOME");
	setenv("HOME", "/proc/no-home", 1); /* not even root can make folders there */
	setenv("TMPDIR", tmpdir, 1);
}

static void test_choice(void)
{
	char note[600], want[300];
	clear_env();
	setenv("POCL_CACHE_DIR", "/somewhere", 1);
	CHECK(mcd_cl_cache_setup(note, sizeof(note)) == 0 && note[0] == 0);
	CHECK(strcmp(getenv("POCL_CACHE_DIR"), "/somewhere") == 0);

	clear_env();
	setenv("XDG_CACHE_HOME", tmpdir, 1); /* PoCL's own choice works: left to it */
	CHECK(mcd_cl_cache_setup(note, sizeof(note)) == 0 && note[0] == 0 && !getenv("POCL_CACHE_DIR"));

	clear_env();
	CHECK(mcd_cl_cache_setup(note, sizeof(note)) == 0);
	const char *got = getenv("POCL_CACHE_DIR");
	snprintf(want, sizeof(want), "%s/mocapd-pocl-%u", tmpdir, (unsigned)geteuid());
	bool var_cache = access("/var/cache/mocapd", W_OK) == 0;
	CHECK_MSG(got && strcmp(got, var_cache ? "/var/cache/mocapd/pocl" : want) == 0, "POCL_CACHE_DIR=%s",
		  got ? got : "(unset)");
	CHECK_MSG(strstr(note, "HOME /proc/no-home has no writable .cache"), "%s", note);
	struct stat st;
	CHECK(var_cache || (stat(want, &st) == 0 && S_ISDIR(st.st_mode) && (st.st_mode & 0777) == 0700));
	rmdir(want);

	/* someone else's link where our folder would be: not taken */
	if (var_cache)
		return;
	clear_env();
	CHECK(symlink("/", want) == 0);
	CHECK(mcd_cl_cache_setup(note, sizeof(note)) == -1 && !getenv("POCL_CACHE_DIR"));
	CHECK_MSG(strstr(note, "no folder for the OpenCL (PoCL) kernel cache") && strstr(note, "set POCL_CACHE_DIR"),
		  "%s", note);
	unlink(want);
}

/* The daemon itself, started by hand with an unusable home: tracks. */
static void test_hand_start(void)
{
	char repo[PATH_MAX];
	mcd_require_files_driver(repo, sizeof(repo));
	mcd_run r;
	CHECK(mcd_run_init(&r));
	char conf[8 * PATH_MAX];
	mcd_demo_clip_config(conf, sizeof(conf), repo, 30, "", "", NULL, "");
	mcd_run_config(&r, conf);
	clear_env(); /* inherited by the daemon */
	const char *args[] = {NULL};
	CHECK(mcd_run_start(&r, args, NULL));
	bool ready = mcd_run_wait_notify(&r, "READY=1", 60000);
	CHECK_MSG(ready, "mocapd did not start with HOME=/proc/no-home");
	if (!ready)
		mcd_run_dump(&r, "start");
	/* READY=1 comes after the tracker's OpenCL set-up, which failed */
	mcd_run_signal(&r, SIGTERM);
	mcd_run_wait_exit(&r, 10000);
	char *log = mcd_read_file(r.log);
	CHECK_MSG(log && !strstr(log, "no device on any platform"), "%s", log ? log : "");
	CHECK(log && strstr(log, "OpenCL kernel cache: POCL_CACHE_DIR="));
	free(log);
	mcd_run_cleanup(&r);
}

int main(void)
{
	CHECK(mkdtemp(tmpdir) != NULL);
	test_choice();
	test_hand_start();
	char own[300];
	snprintf(own, sizeof(own), "rm -rf %s", tmpdir);
	CHECK(system(own) == 0);
	return mc_test_finish("test_daemon_cl_cache");
}
