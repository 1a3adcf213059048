/* [network]: mocapd's TCP listener end to end.  The bundled clip plays in
 * a loop; a client on TCP (libmocap, tcp://) receives the same frames as a
 * client on the Unix socket, a wrong token is refused and logged, control
 * is refused to TCP clients by default, and `mocapd --check` refuses a
 * token file that every user may read. */
#include "daemon/harness.h"
#include "mocap.h"
#include "test_util.h"

#include <arpa/inet.h>
#include <netinet/in.h>

#define TOKEN "daemon-test-token-0123456789"
#define FRAMES 12

static char repo[PATH_MAX];
static const char *g_sock; /* the running daemon's Unix socket */

static void write_token(const mcd_run *r, const char *name, mode_t mode, char *path, size_t cap)
{
	snprintf(path, cap, "%s/%s", r->dir, name);
	FILE *f = fopen(path, "w");
	if (f) {
		fprintf(f, "%s\n", TOKEN);
		fclose(f);
	}
	chmod(path, mode);
}

static void write_config(mcd_run *r, const char *token_file)
{
	char text[8 * PATH_MAX], net[PATH_MAX + 128];
	snprintf(net, sizeof(net), "[network]\nlisten = 127.0.0.1:0\ntoken_file = %s\n", token_file);
	mcd_demo_clip_config(text, sizeof(text), repo, 10, "", "", NULL, net);
	mcd_run_config(r, text);
}

/* The port from "network: TCP clients on 127.0.0.1:0 (port N)". */
static int logged_port(const mcd_run *r)
{
	char *log = mcd_read_file(r->log);
	const char *p = log ? strstr(log, "(port ") : NULL;
	int port = p ? atoi(p + 6) : 0;
	free(log);
	return port;
}

/* Frames from both clients, matched by sequence number. */
static void same_frames(mocap_client *u, mocap_client *t)
{
	static mocap_skeleton_frame fu[FRAMES], ft;
	int nu = 0, matched = 0, equal = 0;
	for (; nu < FRAMES; nu++)
		if (mocap_read_frame(u, &fu[nu], 10000) != 1)
			break;
	CHECK(nu == FRAMES);
	for (int k = 0; k < 4 * FRAMES && matched < nu; k++) {
		if (mocap_read_frame(t, &ft, 10000) != 1)
			break;
		for (int i = 0; i < nu; i++) {
			if (fu[i].seq != ft.seq)
				continue;
			matched++;
			bool eq = fu[i].njoints == ft.njoints && fu[i].capture_ns == ft.capture_ns;
			for (int j = 0; eq && j < ft.njoints; j++) {
				const mocap_joint *a = &fu[i].joints[j], *b = &ft.joints[j];
				eq = !memcmp(a->position, b->position, sizeof(a->position)) &&
				     !memcmp(a->orientation, b->orientation, sizeof(a->orientation)) &&
				     a->confidence == b->confidence;
			}
			equal += eq;
		}
	}
	printf("%d frames on the Unix socket, %d of them also read on TCP, %d identical\n", nu, matched, equal);
	CHECK_MSG(matched == nu && equal == nu, "%d of %d frames matched, %d identical", matched, nu, equal);
}

static void run_clients(mcd_run *r, int port)
{
	char addr[64];
	snprintf(addr, sizeof(addr), "tcp://127.0.0.1:%d", port);
	mocap_client *u = mocap_connect(r->sock, "unix");
	mocap_client *t = mocap_connect_token(addr, "tcp", TOKEN);
	CHECK_MSG(u && t, "%s", mocap_errmsg());
	if (u && t) {
		/* Both subscribed before any frame is read: the TCP client
		 * gets every frame the Unix one gets. */
		CHECK(mocap_subscribe(t, MOCAP_ALL, MOCAP_SPACE_RIG, 0) == 0);
		CHECK(mocap_subscribe(u, MOCAP_ALL, MOCAP_SPACE_RIG, 0) == 0);
		same_frames(u, t);
		char msg[256];
		CHECK(mocap_control(t, MOCAP_CMD_RELOAD, NULL, msg, sizeof(msg)) == MOCAP_E_PERMISSION);
		mocap_daemon_status st;
		CHECK(mocap_get_status(t, &st) == 0 && st.clients == 2 && st.ncams == 2);
	}
	mocap_close(u);
	mocap_close(t);
	CHECK(mocap_connect_token(addr, "bad", "not-the-token-at-all") == NULL && mocap_errcode() == MOCAP_E_ACCESS);
	CHECK(mcd_run_wait_log(r, "refused: wrong token", 5000));
}

/* The daemon under 64 TCP connections that never authenticate (issue 34:
 * they once locked out every Unix-socket client): a local client still
 * connects, and is answered, within 1 s. */
static void tcp_flood(int port)
{
	enum { FLOOD = 64 };
	int fds[FLOOD], opened = 0;
	struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = htons((uint16_t)port)};
	a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	for (int i = 0; i < FLOOD; i++) {
		fds[i] = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
		if (fds[i] >= 0 && connect(fds[i], (struct sockaddr *)&a, sizeof(a)) != 0) {
			close(fds[i]);
			fds[i] = -1;
		}
		opened += fds[i] >= 0;
	}
	mcd_sleep_ms(300); /* the daemon accepts them */
	uint64_t start = mcd_now_ms();
	mocap_client *c = mocap_connect(g_sock, "local-during-flood");
	uint64_t t = 0;
	bool pinged = c && mocap_ping(c, &t) == 0;
	uint64_t ms = mcd_now_ms() - start;
	printf("%d unauthenticated TCP connections; a Unix client %s in %llu ms\n", opened,
	       pinged ? "connected and answered" : "failed", (unsigned long long)ms);
	CHECK(opened == FLOOD);
	CHECK_MSG(pinged && ms < 1000, "a Unix client during the flood: %s, %llu ms", c ? "connected" : mocap_errmsg(),
		  (unsigned long long)ms);
	mocap_close(c);
	for (int i = 0; i < FLOOD; i++)
		if (fds[i] >= 0)
			close(fds[i]);
}

/* --check reads the token file and refuses one anyone may read. */
static void check_world_readable(void)
{
	mcd_run r;
	CHECK(mcd_run_init(&r));
	char token[PATH_MAX];
	write_token(&r, "token", 0644, token, sizeof(token));
	write_config(&r, token);
	const char *const args[] = {"--check", NULL};
	CHECK(mcd_run_start(&r, args, NULL));
	CHECK(mcd_run_wait_exit(&r, 30000) != 0);
	CHECK(mcd_run_wait_log(&r, "token_file", 1000) && mcd_run_wait_log(&r, "readable by every user", 1000));
	if (mc_test_failures)
		mcd_run_dump(&r, "--check with a world-readable token");
	mcd_run_cleanup(&r);
}

int main(void)
{
	mcd_require_build_and_clip(repo, sizeof(repo));
	check_world_readable();
	mcd_run r;
	CHECK(mcd_run_init(&r));
	char token[PATH_MAX];
	write_token(&r, "token", 0600, token, sizeof(token));
	write_config(&r, token);
	const char *const args[] = {NULL};
	if (!mcd_run_start_ready(&r, args))
		return mc_test_finish("test_daemon_network");
	int port = logged_port(&r);
	CHECK_MSG(port > 0, "no 'network: ... (port N)' line in the log");
	g_sock = r.sock;
	if (port > 0) {
		run_clients(&r, port);
		tcp_flood(port);
	}
	mcd_run_stop(&r, 20000, "network");
	return mc_test_finish("test_daemon_network");
}
