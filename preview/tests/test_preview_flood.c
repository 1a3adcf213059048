/* mocap-preview under connection floods (issue 34 item 2), each from
 * several loopback addresses so that the per-address limit does not stop
 * them: 64 connections sending a header line every second (a request
 * whose headers never end), then 64 event streams that never read.
 * During each, the page loads within 2 s; the slow requests are closed
 * once their headers are GUARD_HEADER_S (10 s) late, and streams past
 * GUARD_MAX_STREAMS get 503.  Before the guard, the first flood held every
 * connection slot (a header line every 20 s kept resetting the 60 s idle
 * timeout), and so did the second. */
#include "preview_fixture.h"

#include <poll.h>

enum { FLOOD = 64 };

/* A connection to port from 127.0.0.(2 + i % 4). */
static int connect_from(int port, int i)
{
	int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
	struct sockaddr_in src = {.sin_family = AF_INET}, dst = {.sin_family = AF_INET, .sin_port = htons((uint16_t)port)};
	src.sin_addr.s_addr = htonl(INADDR_LOOPBACK + 2 + (uint32_t)(i % 4));
	dst.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	int small = 4096; /* a stream that does not read fills this soon */
	setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &small, sizeof(small));
	if (fd >= 0 && (bind(fd, (struct sockaddr *)&src, sizeof(src)) != 0 ||
			connect(fd, (struct sockaddr *)&dst, sizeof(dst)) != 0)) {
		close(fd);
		return -1;
	}
	return fd;
}

static void send_all(int *fds, const char *text)
{
	for (int i = 0; i < FLOOD; i++)
		if (fds[i] >= 0 && send(fds[i], text, strlen(text), MSG_NOSIGNAL | MSG_DONTWAIT) < 0 && errno != EAGAIN) {
			close(fds[i]);
			fds[i] = -1;
		}
}

/* The page (GET /, 200) and the time it took, in ms; -1: not served in
 * 2 s.  A connection closed before the answer is tried again, as a
 * browser does for a GET (a new connection may be the one the guard
 * closes when the flood's are all under a second old). */
static double page_ms(int port)
{
	uint64_t t0 = mcd_now_ms();
	while (mcd_now_ms() - t0 < 2000) {
		char *resp;
		int status = pv_http(port, "GET", "/", "", &resp);
		free(resp);
		if (status == 200)
			return (double)(mcd_now_ms() - t0);
		if (status != 0)
			return -1;
	}
	return -1;
}

/* Connections the server closed (the end of the stream, or a reset). */
static int closed_by_server(const int *fds)
{
	int n = 0;
	for (int i = 0; i < FLOOD; i++) {
		char buf[4096];
		struct pollfd p = {.fd = fds[i], .events = POLLIN};
		if (fds[i] < 0)
			n++;
		else if (poll(&p, 1, 0) == 1 && recv(fds[i], buf, sizeof(buf), MSG_DONTWAIT) <= 0)
			n++;
	}
	return n;
}

static void slow_headers(int port)
{
	int fds[FLOOD];
	char head[128];
	snprintf(head, sizeof(head), "GET / HTTP/1.1\r\nHost: 127.0.0.1:%d\r\n", port);
	for (int i = 0; i < FLOOD; i++)
		fds[i] = connect_from(port, i);
	send_all(fds, head);
	double first = -2, late = -2;
	for (int s = 1; s <= 13; s++) {
		mcd_sleep_ms(1000);
		send_all(fds, "X-Slow: a header line a second\r\n");
		if (s == 3)
			first = page_ms(port);
	}
	late = page_ms(port);
	int closed = closed_by_server(fds);
	printf("slow headers: the page in %.0f ms after 3 s, %.0f ms after 13 s; %d of %d closed by the server\n",
	       first, late, closed, FLOOD);
	CHECK_MSG(first >= 0 && first < 2000, "the page during the slow-header flood: %.0f ms", first);
	CHECK_MSG(late >= 0 && late < 2000, "the page after 13 s of it: %.0f ms", late);
	CHECK_MSG(closed == FLOOD, "%d of %d requests whose headers never end were closed", closed, FLOOD);
	for (int i = 0; i < FLOOD; i++)
		if (fds[i] >= 0)
			close(fds[i]);
}

static void unread_streams(int port)
{
	int fds[FLOOD];
	char req[160];
	snprintf(req, sizeof(req), "GET /events HTTP/1.1\r\nHost: 127.0.0.1:%d\r\nAccept: text/event-stream\r\n\r\n", port);
	for (int i = 0; i < FLOOD; i++)
		fds[i] = connect_from(port, i);
	send_all(fds, req);
	mcd_sleep_ms(1000);
	double ms = page_ms(port);
	int refused = 0;
	for (int i = 0; i < FLOOD; i++) {
		char buf[256] = "";
		struct pollfd p = {.fd = fds[i], .events = POLLIN};
		ssize_t n = fds[i] >= 0 && poll(&p, 1, 0) == 1 ? recv(fds[i], buf, sizeof(buf) - 1, MSG_PEEK) : 1;
		if (fds[i] < 0 || n <= 0 || strstr(buf, " 503 ")) /* refused, or closed in the burst */
			refused++;
	}
	printf("unread streams: the page in %.0f ms; %d of %d streams refused (503) or closed\n", ms, refused, FLOOD);
	CHECK_MSG(ms >= 0 && ms < 2000, "the page during the stream flood: %.0f ms", ms);
	CHECK_MSG(refused >= FLOOD - 16, "only %d of %d streams refused", refused, FLOOD);
	for (int i = 0; i < FLOOD; i++)
		if (fds[i] >= 0)
			close(fds[i]);
}

int main(void)
{
	pv_setup();
	mcd_run r;
	CHECK(mcd_run_init(&r));
	pv_run p;
	if (!pv_start(&p, r.dir, r.sock, NULL))
		return mc_test_finish("test_preview_flood");
	int fd = connect_from(p.port, 0);
	if (fd < 0) {
		pv_stop(&p);
		mcd_run_cleanup(&r);
		TEST_SKIP("cannot connect from 127.0.0.2 (no 127.0.0.0/8 loopback here)");
	}
	close(fd);
	slow_headers(p.port);
	mcd_sleep_ms(500);
	unread_streams(p.port);
	CHECK(pv_stop(&p) == 0);
	mcd_run_cleanup(&r);
	return mc_test_finish("test_preview_flood");
}
