/* bench_vmc: publish-to-datagram latency of mocap-vmc on loopback.
 *
 * mocap-testpub publishes at --rate HZ (default 100); mocap-vmc subscribes
 * and sends one VMC bundle per frame to a UDP socket here, which stamps
 * each datagram on arrival (CLOCK_MONOTONIC, the daemon's clock too).
 * This program also subscribes, to learn each frame's publish_ns and
 * pelvis position; a bundle is matched to its frame by the Hips position
 * (testpub's pelvis sways, so every frame's differs).  Prints p50/p99/max
 * of arrival minus publish, and the same for this program's own socket
 * subscription beside it.
 *
 *   bench_vmc [--seconds S] [--rate HZ]      (from <build>/vmc/bench_vmc) */
#include "base/mc_stats.h"
#include "base/mc_time.h"
#include "daemon/harness.h"
#include "mocap.h"
#include "tests/lo_args.h"

#include <getopt.h>
#include <netinet/in.h>
#include <pthread.h>

#define MAX_SAMPLES 65536

typedef struct {
	uint64_t publish_ns, receive_ns;
	double x;
} published;

static published frames[MAX_SAMPLES];
static int nframes;
static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
static volatile int done;

typedef struct {
	uint64_t t_ns;
	double x;
} arrival;

static arrival arrivals[MAX_SAMPLES];
static int narrivals;
static double hips_x;
static bool have_hips;

static void *read_frames(void *arg)
{
	mocap_client *c = arg;
	static mocap_skeleton_frame f;
	while (!done) {
		if (mocap_read_frame(c, &f, 100) != 1)
			continue;
		pthread_mutex_lock(&lock);
		if (nframes < MAX_SAMPLES)
			frames[nframes++] = (published){f.publish_ns, f.receive_ns, f.joints[0].position[0]};
		pthread_mutex_unlock(&lock);
	}
	return NULL;
}

static int on_bone(const char *path, const char *types, lo_arg **argv, int argc, lo_message m, void *user)
{
	(void)path, (void)types, (void)argc, (void)m, (void)user;
	if (strcmp((const char *)argv[0], "Hips") == 0) {
		hips_x = lo_arg_float(argv[1]);
		have_hips = true;
	}
	return 0;
}

static void report(const char *what, double *ms, int n)
{
	if (n == 0) {
		printf("%-44s no samples\n", what);
		return;
	}
	mc_stats_sort(ms, (size_t)n);
	printf("%-44s %6d samples  p50 %.3f ms  p99 %.3f ms  max %.3f ms\n", what, n,
	       mc_stats_percentile(ms, (size_t)n, 50), mc_stats_percentile(ms, (size_t)n, 99), ms[n - 1]);
}

/* Arrival minus publish of the frame whose pelvis x the bundle carries
 * (Unity x = the z-up world's x), the newest such frame published before
 * the arrival; -1 when none matches. */
static double match(int i)
{
	for (int k = nframes - 1; k >= 0; k--)
		if (frames[k].publish_ns <= arrivals[i].t_ns && fabs(frames[k].x - arrivals[i].x) < 2e-6)
			return (double)(arrivals[i].t_ns - frames[k].publish_ns) * 1e-6;
	return -1;
}

int main(int argc, char **argv)
{
	double seconds = 10, rate = 100;
	static const struct option opts[] = {{"seconds", required_argument, NULL, 's'},
					     {"rate", required_argument, NULL, 'r'}, {NULL, 0, NULL, 0}};
	int o;
	while ((o = getopt_long(argc, argv, "", opts, NULL)) != -1) {
		if (o == 's')
			seconds = atof(optarg);
		else if (o == 'r')
			rate = atof(optarg);
		else
			return 2;
	}
	char build[PATH_MAX], vmc[PATH_MAX + 32], pub[PATH_MAX + 32];
	if (!mc_test_build_dir(2, build, sizeof(build))) /* <build>/vmc/bench_vmc */
		TEST_SKIP("cannot find the build folder");
	snprintf(vmc, sizeof(vmc), "%s/bin/mocap-vmc", build);
	snprintf(pub, sizeof(pub), "%s/ipc/mocap-testpub", build);
	char dir[] = "/tmp/bench-vmc-XXXXXX", sock[128], out[128], rate_s[32], target[64];
	if (!mkdtemp(dir))
		return 1;
	snprintf(sock, sizeof(sock), "%s/pub.sock", dir);
	snprintf(out, sizeof(out), "%s/out.txt", dir);
	snprintf(rate_s, sizeof(rate_s), "%g", rate);

	/* The receiving socket: plain UDP, stamped on arrival. */
	int udp = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
	struct sockaddr_in a = {.sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK)};
	socklen_t alen = sizeof(a);
	if (udp < 0 || bind(udp, (struct sockaddr *)&a, sizeof(a)) < 0 || getsockname(udp, (struct sockaddr *)&a, &alen) < 0)
		return 1;
	snprintf(target, sizeof(target), "127.0.0.1:%d", ntohs(a.sin_port));
	lo_server decoder = lo_server_new_with_proto(NULL, LO_UDP, NULL); /* dispatches the datagrams read here */
	lo_server_add_method(decoder, "/VMC/Ext/Bone/Pos", "sfffffff", on_bone, NULL);

	const char *const pub_args[] = {"--socket", sock, "--rate", rate_s, NULL};
	pid_t pub_pid = mcd_spawn(pub, pub_args, out);
	for (int i = 0; i < 500 && !mcd_can_connect(sock); i++)
		mcd_sleep_ms(10);
	mocap_client *c = mocap_connect(sock, "bench_vmc");
	if (!c || mocap_subscribe(c, MOCAP_ALL, MOCAP_SPACE_RIG, 0) < 0) {
		fprintf(stderr, "bench_vmc: %s\n", mocap_errmsg());
		return 1;
	}
	pthread_t th;
	pthread_create(&th, NULL, read_frames, c);
	const char *const vmc_args[] = {"--socket", sock, "--target", target, "--quiet", NULL};
	char vout[160];
	snprintf(vout, sizeof(vout), "%s/vmc.txt", dir);
	pid_t vmc_pid = mcd_spawn(vmc, vmc_args, vout);

	uint64_t end = mc_now_ns() + (uint64_t)(seconds * 1e9);
	static char buf[65536];
	while (mc_now_ns() < end && narrivals < MAX_SAMPLES) {
		struct pollfd p = {.fd = udp, .events = POLLIN};
		if (poll(&p, 1, 100) != 1)
			continue;
		ssize_t n = recv(udp, buf, sizeof(buf), 0);
		uint64_t t = mc_now_ns();
		have_hips = false;
		if (n > 0)
			lo_server_dispatch_data(decoder, buf, (size_t)n);
		if (have_hips)
			arrivals[narrivals++] = (arrival){t, hips_x};
	}
	kill(vmc_pid, SIGTERM);
	mcd_wait_pid(vmc_pid, 5000);
	done = 1;
	pthread_join(th, NULL);
	mocap_close(c);
	kill(pub_pid, SIGTERM);
	mcd_wait_pid(pub_pid, 5000);

	static double vmc_ms[MAX_SAMPLES], sock_ms[MAX_SAMPLES];
	int nv = 0, unmatched = 0;
	for (int i = 0; i < narrivals; i++) {
		double ms = match(i);
		if (ms >= 0)
			vmc_ms[nv++] = ms;
		else
			unmatched++;
	}
	for (int k = 0; k < nframes; k++)
		sock_ms[k] = (double)(frames[k].receive_ns - frames[k].publish_ns) * 1e-6;
	printf("bench_vmc: mocap-testpub at %g Hz for %g s, mocap-vmc to UDP on loopback\n", rate, seconds);
	report("publish -> VMC datagram received", vmc_ms, nv);
	report("publish -> FRAME received (socket, beside)", sock_ms, nframes);
	printf("bench_vmc: %d datagrams, %d not matched to a frame\n", narrivals, unmatched);
	lo_server_free(decoder);
	close(udp);
	char cmd[64];
	snprintf(cmd, sizeof(cmd), "rm -rf %s", dir);
	return system(cmd) == 0 && nv > 0 ? 0 : 1;
}
