/* What the mocap-preview tests share: running mocap-preview on a free port,
 * a small HTTP client (raw requests, so that malformed ones can be sent
 * too), reading the event stream, and mocapd on the bundled clip with a
 * take directory. */
#ifndef PREVIEW_FIXTURE_H
#define PREVIEW_FIXTURE_H

#include "daemon/harness.h"
#include "mocap.h"

#include <arpa/inet.h>
#include <netinet/in.h>

static char pv_bin[PATH_MAX + 32], pv_repo[PATH_MAX];

/* Finds mocap-preview and mocapd next to the test (<build>/preview/tests/T)
 * and the repository root; skips when they are not there. */
static inline void pv_setup(void)
{
	if (!mcd_find_build_up(3))
		TEST_SKIP("mocapd is not built");
	snprintf(pv_bin, sizeof(pv_bin), "%s/bin/mocap-preview", mcd_build_dir);
	if (access(pv_bin, X_OK) != 0)
		TEST_SKIP("mocap-preview is not built");
	if (!getcwd(pv_repo, sizeof(pv_repo)) || access("tests/data/ego_demo/gt.json", R_OK) != 0 ||
	    access("preview/www/index.html", R_OK) != 0)
		TEST_SKIP("run from the repository root (tests/data/ego_demo, preview/www not found)");
	signal(SIGPIPE, SIG_IGN);
}

typedef struct {
	pid_t pid;
	int port;
	char out[192], token_file[192], token[128];
} pv_run;

/* Starts mocap-preview on 127.0.0.1, a free port, for the daemon at sock,
 * with a token file in dir; waits for its "serving" line.  extra: more
 * arguments (NULL-terminated, may be NULL). */
static inline bool pv_start(pv_run *p, const char *dir, const char *sock, const char *const *extra)
{
	memset(p, 0, sizeof(*p));
	snprintf(p->out, sizeof(p->out), "%s/preview.txt", dir);
	snprintf(p->token_file, sizeof(p->token_file), "%s/preview.token", dir);
	const char *args[24] = {"--socket", sock, "--listen", "127.0.0.1:0", "--www", "preview/www",
				"--model", "config/models/default.json", "--token-file", p->token_file};
	int n = 10;
	for (int i = 0; extra && extra[i] && n < 23; i++)
		args[n++] = extra[i];
	args[n] = NULL;
	p->pid = mcd_spawn(pv_bin, args, p->out);
	for (int i = 0; i < 500; i++) {
		char *log = mcd_read_file(p->out);
		const char *s = log ? strstr(log, "serving http://127.0.0.1:") : NULL;
		if (s)
			p->port = atoi(s + strlen("serving http://127.0.0.1:"));
		free(log);
		if (p->port > 0)
			break;
		mcd_sleep_ms(10);
	}
	char *tok = mcd_read_file(p->token_file);
	snprintf(p->token, sizeof(p->token), "%s", tok ? tok : "");
	p->token[strcspn(p->token, "\n")] = 0;
	free(tok);
	CHECK_MSG(p->port > 0 && strlen(p->token) >= 16, "mocap-preview did not start (port %d, token '%s')", p->port,
		  p->token);
	return p->port > 0;
}

/* SIGTERM; its exit status. */
static inline int pv_stop(pv_run *p)
{
	if (p->pid <= 0)
		return -1;
	kill(p->pid, SIGTERM);
	int rc = mcd_wait_pid(p->pid, 15000);
	p->pid = -1;
	return rc;
}

static inline int pv_connect(int port)
{
	int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
	struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = htons((uint16_t)port)};
	a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	if (fd >= 0 && connect(fd, (struct sockaddr *)&a, sizeof(a)) != 0) {
		close(fd);
		return -1;
	}
	return fd;
}

/* Sends raw request text, reads for up to ms milliseconds or until the
 * server closes.  The HTTP status (0: none) and the malloc'd response
 * (headers and body) in *resp. */
static inline int pv_raw(int port, const char *request, int ms, char **resp)
{
	*resp = calloc(1, 1);
	int fd = pv_connect(port);
	if (fd < 0)
		return 0;
	if (write(fd, request, strlen(request)) != (ssize_t)strlen(request)) {
		close(fd);
		return 0;
	}
	size_t len = 0, cap = 0;
	uint64_t end = mcd_now_ms() + (uint64_t)ms;
	while (mcd_now_ms() < end) {
		struct pollfd pfd = {.fd = fd, .events = POLLIN};
		if (poll(&pfd, 1, (int)(end - mcd_now_ms())) <= 0)
			break;
		if (len + 65536 + 1 > cap) {
			cap = (len + 65536 + 1) * 2;
			char *grown = realloc(*resp, cap);
			if (!grown)
				break;
			*resp = grown;
		}
		ssize_t n = read(fd, *resp + len, 65536);
		if (n <= 0)
			break;
		len += (size_t)n;
		(*resp)[len] = 0;
	}
	close(fd);
	int status = 0;
	if (strncmp(*resp, "HTTP/1.", 7) == 0)
		status = atoi(*resp + 9);
	return status;
}

/* A request: method, path, extra header lines ("" for none). */
static inline int pv_http(int port, const char *method, const char *path, const char *headers, char **resp)
{
	char req[2048];
	snprintf(req, sizeof(req), "%s %s HTTP/1.1\r\nHost: 127.0.0.1:%d\r\nConnection: close\r\nContent-Length: 0\r\n%s\r\n",
		 method, path, port, headers);
	return pv_raw(port, req, 10000, resp);
}

/* The body of a response. */
static inline const char *pv_body(const char *resp)
{
	const char *b = strstr(resp, "\r\n\r\n");
	return b ? b + 4 : "";
}

/* mocapd on the bundled clip at `rate` fps with takes in dir/takes. */
static inline bool pv_daemon(mcd_run *r, int rate)
{
	static char conf[65536], extra[PATH_MAX + 64];
	snprintf(extra, sizeof(extra), "[record]\ndirectory = %s/takes\n", r->dir);
	mcd_demo_clip_config(conf, sizeof(conf), pv_repo, rate, "", "", NULL, extra);
	mcd_run_config(r, conf);
	const char *const args[] = {NULL};
	return mcd_run_start_ready(r, args);
}

/* Base64 (standard alphabet) into a malloc'd buffer; its length in *n. */
static inline uint8_t *pv_base64_decode(const char *s, size_t len, size_t *n)
{
	uint8_t *out = malloc(len / 4 * 3 + 3);
	uint32_t acc = 0;
	int bits = 0;
	*n = 0;
	for (size_t i = 0; out && i < len && s[i] != '='; i++) {
		const char *abc = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
		const char *p = strchr(abc, s[i]);
		if (!p || !s[i])
			continue;
		acc = acc << 6 | (uint32_t)(p - abc);
		bits += 6;
		if (bits >= 8) {
			bits -= 8;
			out[(*n)++] = (uint8_t)(acc >> bits);
		}
	}
	return out;
}

/* Counts the pixels of packed RGB within tol of colour c in every channel. */
static inline int pv_count_colour(const uint8_t *rgb, int w, int h, const uint8_t c[3], int tol)
{
	int n = 0;
	for (int i = 0; i < w * h; i++)
		n += abs(rgb[3 * i] - c[0]) <= tol && abs(rgb[3 * i + 1] - c[1]) <= tol && abs(rgb[3 * i + 2] - c[2]) <= tol;
	return n;
}

/* Whether mocapd records (its status), -1 when it cannot be asked. */
static inline int pv_recording(const char *sock)
{
	mocap_client *c = mocap_connect(sock, "test_preview");
	static mocap_daemon_status st;
	int rc = c && mocap_get_status(c, &st) == 0 ? st.recording : -1;
	if (c)
		mocap_close(c);
	return rc;
}

/* The daemon's status says `want` within ms milliseconds (the recorder
 * thread opens and closes the take after the control request returned). */
static inline bool pv_recording_becomes(const char *sock, int want, int ms)
{
	for (int waited = 0; waited < ms; waited += 100) {
		if (pv_recording(sock) == want)
			return true;
		mcd_sleep_ms(100);
	}
	return false;
}

#endif
