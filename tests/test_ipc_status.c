/* The STATUS message's detector through libmocap (protocol version 2),
 * against the server library. */
#include "server.h"
#include "mocap.h"
#include "test_util.h"

#include <dlfcn.h>
#include <errno.h>
#include <limits.h>
#include <stddef.h>
#include <string.h>
#include <unistd.h>

static char dir[48], path[96];

/* mocap_daemon_status and its two symbol versions: the status with the
 * detector (MOCAP_2, what mocap.h declares), and for programs built
 * against libmocap 1.0 (MOCAP_1) the old layout, nothing written past it.
 * Through the shared library built beside this test (<build>/lib). */
static void test_status_versions(void)
{
	srv_config cfg;
	srv_config_default(&cfg);
	snprintf(cfg.path, sizeof(cfg.path), "%s", path);
	mc_err err = {{0}};
	srv_server *srv = srv_create(&cfg, &err);
	CHECK_MSG(srv, "%s", err.msg);
	if (!srv)
		return;
	srv_status st = {0};
	st.ncams = 1;
	snprintf(st.cams[0].name, sizeof(st.cams[0].name), "left");
	st.detector.state = SRV_DETECTOR_RUNNING;
	st.detector.ms_mean = 1.5;
	st.detector.used = 9;
	snprintf(st.detector.model, sizeof(st.detector.model), "m.onnx");
	srv_set_status(srv, &st);
	mocap_client *c = mocap_connect(path, "status");
	mocap_daemon_status *ds = calloc(1, sizeof(*ds));
	CHECK(c && ds && mocap_get_status(c, ds) == 0);
	CHECK(ds && ds->detector.state == MOCAP_DETECTOR_RUNNING && ds->detector.ms_mean == 1.5 && ds->detector.used == 9);
	CHECK(ds && strcmp(ds->detector.model, "m.onnx") == 0 && strcmp(ds->cams[0].name, "left") == 0);
	mocap_close(c);

	char so[PATH_MAX];
	ssize_t n = readlink("/proc/self/exe", so, sizeof(so) - 32);
	so[n > 0 ? n : 0] = 0;
	char *slash = strrchr(so, '/');
	if (slash)
		*slash = 0; /* <build>/tests */
	slash = strrchr(so, '/');
	snprintf(slash ? slash : so, sizeof(so) - (size_t)(slash ? slash - so : 0), "/lib/libmocap.so.1");
	void *h = dlopen(so, RTLD_NOW | RTLD_LOCAL);
	if (!h)
		printf("%s: %s; the symbol versions are not checked\n", so, dlerror());
	else {
		typedef mocap_client *(*connect_fn)(const char *, const char *);
		typedef int (*status_fn)(mocap_client *, void *);
		connect_fn con = (connect_fn)dlsym(h, "mocap_connect");
		void (*cls)(mocap_client *) = (void (*)(mocap_client *))dlsym(h, "mocap_close");
		status_fn v1 = (status_fn)dlvsym(h, "mocap_get_status", "MOCAP_1");
		status_fn v2 = (status_fn)dlvsym(h, "mocap_get_status", "MOCAP_2");
		CHECK(con && cls && v1 && v2 && (void *)v1 != (void *)v2);
		CHECK((void *)dlsym(h, "mocap_get_status") == (void *)v2); /* the default */
		mocap_client *sc = con ? con(path, "status-so") : NULL;
		size_t old = offsetof(mocap_daemon_status, detector);
		unsigned char *buf = malloc(old + 64);
		if (sc && buf && v1 && v2) {
			memset(buf, 0xa5, old + 64);
			CHECK(v1(sc, buf) == 0);
			bool untouched = true;
			for (size_t i = old; i < old + 64; i++)
				untouched &= buf[i] == 0xa5;
			CHECK_MSG(untouched, "mocap_get_status@MOCAP_1 wrote past the 1.0 layout");
			int ncams;
			memcpy(&ncams, buf + offsetof(mocap_daemon_status, ncams), sizeof(ncams));
			CHECK(ncams == 1);
			memset(ds, 0, sizeof(*ds));
			CHECK(v2(sc, ds) == 0 && ds->detector.used == 9);
		}
		free(buf);
		if (sc)
			cls(sc);
		dlclose(h);
	}
	free(ds);
	srv_destroy(srv);
}

int main(void)
{
	snprintf(dir, sizeof(dir), "/tmp/mocap-ipc-XXXXXX");
	if (!mkdtemp(dir))
		TEST_SKIP("cannot create a temporary directory: %s", strerror(errno));
	snprintf(path, sizeof(path), "%s/mocapd.sock", dir);
	test_status_versions();
	rmdir(dir);
	return mc_test_finish("test_ipc_status");
}
