/* The daemon's version at the client (issue 31): libmocap keeps what the
 * daemon says in WELCOME (mocap_daemon_version, mocap_protocol_version),
 * and `mocapctl --version` prints it after its own, or "daemon: not
 * running" and exit 0 when nothing listens. */
#include "server.h"
#include "mocap.h"
#include "test_util.h"

static char mocapctl[4096];

/* mocapctl ARGS' stdout into out; its exit status. */
static int run_ctl(const char *args, char *out, size_t cap)
{
	char cmd[8192];
	snprintf(cmd, sizeof(cmd), "%s %s 2>/dev/null", mocapctl, args);
	FILE *p = popen(cmd, "r");
	if (!p)
		return -1;
	size_t n = fread(out, 1, cap - 1, p);
	out[n] = 0;
	int st = pclose(p);
	return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

static void test_with_daemon(const char *path)
{
	srv_config cfg;
	srv_config_default(&cfg);
	snprintf(cfg.path, sizeof(cfg.path), "%s", path);
	snprintf(cfg.daemon_version, sizeof(cfg.daemon_version), "mocapd 9.8.7");
	mc_err err = {{0}};
	srv_server *srv = srv_create(&cfg, &err);
	CHECK_MSG(srv != NULL, "%s", err.msg);
	if (!srv)
		return;
	mocap_client *c = mocap_connect(path, "test_ipc_version");
	CHECK_MSG(c != NULL, "%s", mocap_errmsg());
	if (c) {
		CHECK_MSG(!strcmp(mocap_daemon_version(c), "mocapd 9.8.7"), "daemon version '%s'", mocap_daemon_version(c));
		CHECK(mocap_protocol_version(c) == MOCAP_PROTOCOL_VERSION);
		mocap_close(c);
	}
	char out[4096], want[512];
	char args[600];
	snprintf(args, sizeof(args), "--socket %s --version", path);
	int rc = run_ctl(args, out, sizeof(out));
	printf("mocapctl %s -> %d:\n%s", args, rc, out);
	CHECK(rc == 0);
	snprintf(want, sizeof(want), "mocapctl (libmocap %s, protocol %d)\ndaemon: mocapd 9.8.7, protocol %d, at %s\n",
		 MOCAP_LIB_VERSION, MOCAP_PROTOCOL_VERSION, MOCAP_PROTOCOL_VERSION, path);
	CHECK_MSG(!strcmp(out, want), "expected:\n%s", want);
	srv_destroy(srv);
}

static void test_without_daemon(const char *path)
{
	char out[4096], want[512], args[600];
	snprintf(args, sizeof(args), "-V --socket %s", path);
	int rc = run_ctl(args, out, sizeof(out));
	printf("mocapctl %s -> %d:\n%s", args, rc, out);
	CHECK(rc == 0);
	snprintf(want, sizeof(want), "mocapctl (libmocap %s, protocol %d)\ndaemon: not running (at %s)\n",
		 MOCAP_LIB_VERSION, MOCAP_PROTOCOL_VERSION, path);
	CHECK_MSG(!strcmp(out, want), "expected:\n%s", want);
}

int main(int argc, char **argv)
{
	(void)argc;
	mc_test_find_tool(argv[0], "mocapctl", mocapctl, sizeof(mocapctl));
	char dir[] = "/tmp/mocap-version-XXXXXX";
	CHECK(mkdtemp(dir) != NULL);
	char path[128];
	snprintf(path, sizeof(path), "%s/mocapd.sock", dir);
	test_with_daemon(path);
	test_without_daemon(path);
	unlink(path);
	rmdir(dir);
	return mc_test_finish("test_ipc_version");
}
