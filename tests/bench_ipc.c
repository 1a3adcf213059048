/* bench_ipc: latency from srv_publish() to the client library's
 * receipt of the frame (both CLOCK_MONOTONIC, same machine), at 60 Hz with
 * 1 and with 64 readers of the latest-pose block (waiting on its futex)
 * and subscribers on the Unix socket, and with 1 and 16 over loopback TCP
 * (the [network] listener), each a libmocap client on its own thread; and
 * the cost of a non-blocking read of the block.
 * Also the time the publisher spends in srv_publish().  Target:
 * p99 < 1 ms.
 *
 *   bench_ipc [--rt] [SECONDS per run, default 10]
 *
 * --rt runs every thread (publisher, server, subscribers) with SCHED_FIFO,
 * as a VR deployment might: the figures then show the IPC path without
 * other processes' load on a shared machine (needs CAP_SYS_NICE). */
#include "base/mc_stats.h"
#include "base/mc_time.h"
#include "mocap.h"
#include "server.h"

#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define NJ 18

#define TOKEN "bench-ipc-token-0123456789"

static char path[96], tcp_addr[64];

typedef struct {
	const char *address;
	mocap_mode mode;
	int max_samples, n;
	double *lat_ms;
	atomic_int *ready;
	atomic_bool *stop;
} sub_arg;

/* A reader of the latest-pose block, waiting on its futex. */
static void *block_reader(sub_arg *s)
{
	mocap_client *c = mocap_connect(path, "bench-block");
	mocap_pose_block *b = c ? mocap_pose_block_map(c) : NULL;
	if (!b) {
		fprintf(stderr, "bench_ipc: %s\n", mocap_errmsg());
		exit(1);
	}
	mocap_skeleton_frame *f = malloc(sizeof(*f));
	uint64_t seen = mocap_pose_block_read(b, f) == 1 ? f->seq : 0;
	atomic_fetch_add(s->ready, 1);
	while (!atomic_load(s->stop)) {
		if (mocap_pose_block_wait(b, seen, f, 100) != 1)
			continue;
		seen = f->seq;
		if (s->n < s->max_samples)
			s->lat_ms[s->n++] = (double)(f->receive_ns - f->publish_ns) * 1e-6;
	}
	free(f);
	mocap_pose_block_unmap(b);
	mocap_close(c);
	return NULL;
}

static void *subscriber(void *arg)
{
	sub_arg *s = arg;
	if (!strcmp(s->address, "block"))
		return block_reader(s);
	mocap_client *c = mocap_connect_token(s->address, "bench", TOKEN);
	if (!c || mocap_subscribe(c, s->mode, MOCAP_SPACE_RIG, 0) != 0) {
		fprintf(stderr, "bench_ipc: %s\n", mocap_errmsg());
		exit(1);
	}
	atomic_fetch_add(s->ready, 1);
	mocap_skeleton_frame *f = malloc(sizeof(*f));
	while (!atomic_load(s->stop)) {
		int r = mocap_read_frame(c, f, 100);
		if (r < 0)
			break;
		if (r == 1 && s->n < s->max_samples)
			s->lat_ms[s->n++] = (double)(f->receive_ns - f->publish_ns) * 1e-6;
	}
	free(f);
	mocap_close(c);
	return NULL;
}

/* The p-th percentile (0..100, nearest rank) of n sorted samples. */
static double pct(const double *sorted, int n, double p) { return mc_stats_percentile(sorted, (size_t)n, p); }

static bool run(srv_server *srv, const char *address, int nsubs, mocap_mode mode, int frames)
{
	static uint64_t seq = 0;
	pthread_t th[64];
	sub_arg args[64];
	atomic_int ready = 0;
	atomic_bool stop = false;
	for (int i = 0; i < nsubs; i++) {
		args[i] = (sub_arg){address, mode, frames, 0, calloc((size_t)frames, sizeof(double)), &ready, &stop};
		pthread_create(&th[i], NULL, subscriber, &args[i]);
	}
	while (atomic_load(&ready) < nsubs)
		usleep(1000);
	usleep(100000);

	mc_skeleton *sk = calloc(1, sizeof(*sk));
	sk->njoints = NJ;
	for (int j = 0; j < NJ; j++) {
		sk->joints[j].orientation = mc_quat_identity();
		sk->joints[j].confidence = 1;
	}
	double *pub_us = calloc((size_t)frames, sizeof(double));
	uint64_t period = MC_NS_PER_S / 60, next = mocap_now_ns();
	for (int i = 0; i < frames; i++) {
		next += period;
		mc_sleep_until_ns(next);
		sk->timestamp_ns = mocap_now_ns();
		sk->joints[0].position = mc_v3(i, 0, 0);
		mc_err err;
		uint64_t t0 = mocap_now_ns();
		if (srv_publish(srv, sk, ++seq, &err))
			fprintf(stderr, "bench_ipc: %s\n", err.msg);
		pub_us[i] = (double)(mocap_now_ns() - t0) * 1e-3;
	}
	usleep(200000);
	atomic_store(&stop, true);
	int total = 0;
	for (int i = 0; i < nsubs; i++) {
		pthread_join(th[i], NULL);
		total += args[i].n;
	}
	double *all = calloc((size_t)total + 1, sizeof(double));
	int k = 0;
	for (int i = 0; i < nsubs; i++) {
		memcpy(all + k, args[i].lat_ms, sizeof(double) * (size_t)args[i].n);
		k += args[i].n;
		free(args[i].lat_ms);
	}
	mc_stats_sort(all, (size_t)total);
	mc_stats_sort(pub_us, (size_t)frames);
	double p99 = pct(all, total, 99);
	const char *via = address == path ? "unix" : strcmp(address, "block") ? "tcp" : "block";
	printf("  %-5s %3d   %-6s  %7d/%-7d  %7.3f  %7.3f  %7.3f   %6.1f %6.1f\n", via, nsubs,
	       !strcmp(via, "block") ? "wait" : mode == MOCAP_LATEST ? "latest" : "all", total, frames * nsubs, pct(all, total, 50), p99, total ? all[total - 1] : 0.0, pct(pub_us, frames, 50),
	       pct(pub_us, frames, 99));
	free(all);
	free(pub_us);
	free(sk);
	/* "latest" clients skip frames by design when they fall behind. */
	return p99 < 1.0 && (mode == MOCAP_LATEST || total == frames * nsubs);
}

/* What a non-blocking read of the newest pose costs (18 joints). */
static void read_cost(void)
{
	mocap_client *c = mocap_connect(path, "bench-read");
	mocap_pose_block *b = c ? mocap_pose_block_map(c) : NULL;
	mocap_skeleton_frame *f = malloc(sizeof(*f));
	if (!b || !f || mocap_pose_block_read(b, f) != 1) {
		fprintf(stderr, "bench_ipc: the pose block is not readable: %s\n", mocap_errmsg());
		exit(1);
	}
	enum { N = 1000000 };
	uint64_t t0 = mocap_now_ns();
	for (int i = 0; i < N; i++)
		mocap_pose_block_read(b, f);
	double ns = (double)(mocap_now_ns() - t0) / N;
	printf("  block: a non-blocking read of the newest pose costs %.0f ns (mean of %d); target < 1000 ns\n", ns, N);
	free(f);
	mocap_pose_block_unmap(b);
	mocap_close(c);
}

int main(int argc, char **argv)
{
	bool rt = argc > 1 && strcmp(argv[1], "--rt") == 0;
	if (rt) {
		argc--;
		argv++;
		/* Threads created from here on inherit the policy. */
		struct sched_param sp = {.sched_priority = 10};
		int e = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
		if (e) {
			fprintf(stderr, "bench_ipc: --rt: SCHED_FIFO not allowed here (%s)\n", strerror(e));
			return 77;
		}
	}
	double seconds = argc > 1 ? atof(argv[1]) : 10;
	int frames = (int)(seconds * 60);
	if (frames < 10) {
		fprintf(stderr, "usage: bench_ipc [seconds per run >= 0.2]\n");
		return 2;
	}
	char dir[] = "/tmp/mocap-bench-XXXXXX";
	if (!mkdtemp(dir)) {
		perror("mkdtemp");
		return 1;
	}
	snprintf(path, sizeof(path), "%s/mocapd.sock", dir);
	srv_config cfg;
	srv_config_default(&cfg);
	snprintf(cfg.path, sizeof(cfg.path), "%s", path);
	snprintf(cfg.tcp_listen, sizeof(cfg.tcp_listen), "127.0.0.1:0");
	snprintf(cfg.tcp_token, sizeof(cfg.tcp_token), "%s", TOKEN);
	mc_err err;
	srv_server *srv = srv_create(&cfg, &err);
	if (!srv) {
		fprintf(stderr, "bench_ipc: %s\n", err.msg);
		return 1;
	}
	snprintf(tcp_addr, sizeof(tcp_addr), "tcp://127.0.0.1:%d", srv_tcp_port(srv));
	srv_skeleton_def def = {0};
	def.njoints = NJ;
	for (int j = 0; j < NJ; j++) {
		snprintf(def.name[j], sizeof(def.name[j]), "joint%d", j);
		def.parent[j] = j - 1;
	}
	srv_set_skeleton_def(srv, &def, &err);
	long ncpu = sysconf(_SC_NPROCESSORS_ONLN);
	printf("bench_ipc: publish -> client receive latency, 60 Hz, %d joints (%zu-byte frames), %d frames per run, "
	       "%ld CPUs%s\n", NJ, (size_t)48 + 64 * NJ, frames, ncpu, rt ? ", SCHED_FIFO" : "");
	printf("  via   subs  mode    received         p50 ms   p99 ms   max ms   publish us p50 p99\n");
	/* The latest-pose block first: its target is 0.1 ms p99 with one reader. */
	bool ok = run(srv, "block", 1, MOCAP_LATEST, frames);
	ok &= run(srv, "block", 64, MOCAP_LATEST, frames);
	read_cost();
	ok &= run(srv, path, 1, MOCAP_LATEST, frames);
	ok &= run(srv, path, 64, MOCAP_LATEST, frames);
	ok &= run(srv, path, 1, MOCAP_ALL, frames);
	ok &= run(srv, path, 64, MOCAP_ALL, frames);
	ok &= run(srv, tcp_addr, 1, MOCAP_LATEST, frames);
	ok &= run(srv, tcp_addr, 16, MOCAP_LATEST, frames);
	ok &= run(srv, tcp_addr, 1, MOCAP_ALL, frames);
	ok &= run(srv, tcp_addr, 16, MOCAP_ALL, frames);
	double load[3] = {0};
	FILE *la = fopen("/proc/loadavg", "r");
	if (la) {
		if (fscanf(la, "%lf %lf %lf", &load[0], &load[1], &load[2]) != 3)
			load[0] = -1;
		fclose(la);
	}
	printf("bench_ipc: target p99 < 1 ms (and every frame in \"all\" mode): %s; load average %.2f on %ld CPUs\n",
	       ok ? "met" : "NOT met", load[0], ncpu);
	srv_destroy(srv);
	rmdir(dir);
	return 0;
}
