/* preview_http: routes, static files, the event stream and the token
 * check (preview_http.h). */
#include "preview_http.h"
#include "preview_guard.h"

#include <fcntl.h>
#include <jansson.h>
#include <stdarg.h>
#include <microhttpd.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#define TOKEN_HEADER "X-Mocap-Token"
/* The page may load only from its own origin: the browser itself then
 * enforces "no network" (and no injected script runs). */
#define CSP "default-src 'self'; img-src 'self' data:; connect-src 'self'; style-src 'self'; script-src 'self'"

struct preview_http {
	struct MHD_Daemon *mhd;
	http_config cfg;
	preview_guard *guard;
};

typedef struct {
	const char *path, *dir_kind, *file, *type;
} static_file;

static const static_file files[] = {
	{"/", "www", "index.html", "text/html; charset=utf-8"},
	{"/index.html", "www", "index.html", "text/html; charset=utf-8"},
	{"/preview.js", "www", "preview.js", "text/javascript; charset=utf-8"},
	{"/preview.css", "www", "preview.css", "text/css; charset=utf-8"},
	{"/three/three.min.js", "three", "three.min.js", "text/javascript; charset=utf-8"},
	{"/three/OrbitControls.js", "three", "examples/js/controls/OrbitControls.js", "text/javascript; charset=utf-8"},
};

bool http_token_ok(const char *expected, const char *given)
{
	if (!expected || !given)
		return false;
	size_t n = strlen(expected), m = strlen(given);
	unsigned char diff = (unsigned char)(n != m);
	for (size_t i = 0; i < n; i++)
		diff |= (unsigned char)(expected[i] ^ (i < m ? given[i] : 0));
	return diff == 0;
}

bool http_take_name_ok(const char *name)
{
	size_t n = strlen(name);
	if (n == 0 || n > 64 || name[0] == '.')
		return false;
	for (size_t i = 0; i < n; i++) {
		char c = name[i];
		if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
		      c == '_' || c == '-'))
			return false;
	}
	return true;
}

static void common_headers(struct MHD_Response *r, const char *type)
{
	MHD_add_response_header(r, "Content-Type", type);
	MHD_add_response_header(r, "Cache-Control", "no-store");
	MHD_add_response_header(r, "X-Content-Type-Options", "nosniff");
	MHD_add_response_header(r, "Content-Security-Policy", CSP);
}

static enum MHD_Result reply_text(struct MHD_Connection *conn, unsigned status, const char *type, const char *text)
{
	struct MHD_Response *r = MHD_create_response_from_buffer(strlen(text), (void *)text, MHD_RESPMEM_MUST_COPY);
	if (!r)
		return MHD_NO;
	common_headers(r, type);
	enum MHD_Result rc = MHD_queue_response(conn, status, r);
	MHD_destroy_response(r);
	return rc;
}

static enum MHD_Result reply_error(struct MHD_Connection *conn, unsigned status, const char *msg)
{
	char body[512];
	snprintf(body, sizeof(body), "%s\n", msg);
	return reply_text(conn, status, "text/plain; charset=utf-8", body);
}

static enum MHD_Result serve_file(struct MHD_Connection *conn, const http_config *cfg, const static_file *f)
{
	char path[4096];
	snprintf(path, sizeof(path), "%s/%s", strcmp(f->dir_kind, "www") ? cfg->three_dir : cfg->www_dir, f->file);
	int fd = open(path, O_RDONLY | O_CLOEXEC);
	struct stat st;
	if (fd < 0 || fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
		if (fd >= 0)
			close(fd);
		fprintf(stderr, "mocap-preview: cannot serve %s: %s is missing\n", f->path, path);
		return reply_error(conn, MHD_HTTP_NOT_FOUND, "not installed here");
	}
	struct MHD_Response *r = MHD_create_response_from_fd((uint64_t)st.st_size, fd);
	if (!r) {
		close(fd);
		return MHD_NO;
	}
	common_headers(r, f->type);
	enum MHD_Result rc = MHD_queue_response(conn, MHD_HTTP_OK, r);
	MHD_destroy_response(r);
	return rc;
}

/* ---- the event stream ---- */

typedef struct {
	hub_reader *reader;
	preview_guard *guard; /* counts the open streams */
} sse_stream;

static ssize_t sse_read(void *cls, uint64_t pos, char *buf, size_t max)
{
	(void)pos;
	sse_stream *st = cls;
	long n = hub_reader_read(st->reader, buf, max, 10000);
	return n < 0 ? MHD_CONTENT_READER_END_OF_STREAM : (ssize_t)n;
}

static void sse_free(void *cls)
{
	sse_stream *st = cls;
	hub_reader_free(st->reader);
	guard_stream_end(st->guard);
	free(st);
}

static enum MHD_Result serve_events(struct MHD_Connection *conn, const http_config *cfg, preview_guard *guard)
{
	if (!guard_stream_begin(guard, conn))
		return reply_error(conn, MHD_HTTP_SERVICE_UNAVAILABLE, "too many event streams open; try again later");
	sse_stream *st = calloc(1, sizeof(*st));
	if (!st || !(st->reader = hub_reader_new(cfg->hub))) {
		free(st);
		guard_stream_end(guard);
		return MHD_NO;
	}
	st->guard = guard;
	struct MHD_Response *r = MHD_create_response_from_callback(MHD_SIZE_UNKNOWN, 64 * 1024, sse_read, st, sse_free);
	if (!r) {
		sse_free(st);
		return MHD_NO;
	}
	common_headers(r, "text/event-stream");
	enum MHD_Result rc = MHD_queue_response(conn, MHD_HTTP_OK, r);
	MHD_destroy_response(r);
	return rc;
}

/* ---- state changes ---- */

static unsigned status_for(int rc)
{
	switch (rc) {
	case 0: return MHD_HTTP_OK;
	case MOCAP_E_FAILED:
	case MOCAP_E_REFUSED: return MHD_HTTP_CONFLICT;
	case MOCAP_E_PERMISSION:
	case MOCAP_E_ACCESS: return MHD_HTTP_FORBIDDEN;
	}
	return MHD_HTTP_SERVICE_UNAVAILABLE;
}

static enum MHD_Result serve_control(struct MHD_Connection *conn, const http_config *cfg, const char *url)
{
	const char *token = MHD_lookup_connection_value(conn, MHD_HEADER_KIND, TOKEN_HEADER);
	if (!http_token_ok(cfg->token, token))
		return reply_error(conn, MHD_HTTP_FORBIDDEN,
				   token ? "wrong token (" TOKEN_HEADER ")" : "changing state needs the token (" TOKEN_HEADER ")");
	mocap_command cmd;
	const char *arg = NULL;
	if (!strcmp(url, "/api/record/start")) {
		cmd = MOCAP_CMD_RECORD_START;
		arg = MHD_lookup_connection_value(conn, MHD_GET_ARGUMENT_KIND, "name");
		if (arg && *arg && !http_take_name_ok(arg))
			return reply_error(conn, MHD_HTTP_BAD_REQUEST,
					   "name: 1 to 64 letters, digits, '.', '_' or '-', not starting with '.'");
	} else if (!strcmp(url, "/api/record/stop"))
		cmd = MOCAP_CMD_RECORD_STOP;
	else
		cmd = MOCAP_CMD_RELOAD;
	char msg[1024] = "";
	int rc = cfg->control(cfg->control_ctx, cmd, arg ? arg : "", msg, sizeof(msg));
	json_t *o = json_pack("{s:b, s:s}", "ok", rc == 0, "message", msg);
	char *body = o ? json_dumps(o, JSON_COMPACT) : NULL;
	json_decref(o);
	if (!body)
		return MHD_NO;
	enum MHD_Result r = reply_text(conn, status_for(rc), "application/json", body);
	free(body);
	return r;
}

/* ---- routing ---- */

/* On a loopback address only a loopback Host (DNS rebinding).  host is
 * the request's Host header. */
static bool host_ok(const char *host, const http_config *cfg)
{
	if (!cfg->loopback)
		return true;
	static const char *const names[] = {"127.0.0.1", "localhost", "[::1]"};
	/* The port is the whole rest, as the browser writes it: atoi took
	 * "18089evil" for 18089 (issue 34, Also). */
	char port[16];
	snprintf(port, sizeof(port), "%d", cfg->port);
	for (size_t i = 0; i < sizeof(names) / sizeof(names[0]); i++) {
		size_t n = strlen(names[i]);
		if (!strncasecmp(host, names[i], n) && (host[n] == 0 || (host[n] == ':' && !strcmp(host + n + 1, port))))
			return true;
	}
	return false;
}

static bool is_control(const char *url)
{
	return !strcmp(url, "/api/record/start") || !strcmp(url, "/api/record/stop") || !strcmp(url, "/api/reload");
}

static enum MHD_Result on_request(void *cls, struct MHD_Connection *conn, const char *url, const char *method,
				  const char *version, const char *upload_data, size_t *upload_data_size, void **con_cls)
{
	(void)upload_data;
	preview_http *h = cls;
	const http_config *cfg = &h->cfg;
	static int marker;
	if (*con_cls == NULL) { /* headers only so far: wait for the body */
		guard_headers_done(h->guard, conn);
		*con_cls = &marker;
		return MHD_YES;
	}
	if (*upload_data_size) { /* a body is not used: read and dropped */
		*upload_data_size = 0;
		return MHD_YES;
	}
	/* HTTP/1.1 requires Host (RFC 9112 3.2); HTTP/1.0 clients may omit it. */
	const char *host = MHD_lookup_connection_value(conn, MHD_HEADER_KIND, "Host");
	if (!host && !strcmp(version, MHD_HTTP_VERSION_1_1))
		return reply_error(conn, MHD_HTTP_BAD_REQUEST, "no Host header");
	if (host && !host_ok(host, cfg))
		return reply_error(conn, MHD_HTTP_FORBIDDEN, "Host not allowed");
	bool get = !strcmp(method, MHD_HTTP_METHOD_GET) || !strcmp(method, MHD_HTTP_METHOD_HEAD);
	if (is_control(url))
		return !strcmp(method, MHD_HTTP_METHOD_POST) ? serve_control(conn, cfg, url)
							     : reply_error(conn, MHD_HTTP_METHOD_NOT_ALLOWED, "use POST");
	for (size_t i = 0; i < sizeof(files) / sizeof(files[0]); i++)
		if (!strcmp(url, files[i].path))
			return get ? serve_file(conn, cfg, &files[i])
				   : reply_error(conn, MHD_HTTP_METHOD_NOT_ALLOWED, "use GET");
	if (!strcmp(url, "/favicon.ico")) /* browsers ask; none, and no error for it */
		return reply_text(conn, MHD_HTTP_NO_CONTENT, "image/x-icon", "");
	if (!strcmp(url, "/events"))
		return get ? serve_events(conn, cfg, h->guard) : reply_error(conn, MHD_HTTP_METHOD_NOT_ALLOWED, "use GET");
	return reply_error(conn, MHD_HTTP_NOT_FOUND, "not found");
}

static void log_mhd(void *cls, const char *fmt, va_list ap)
{
	(void)cls;
	char msg[1024];
	vsnprintf(msg, sizeof(msg), fmt, ap);
	/* A page closed while its event stream was open: routine, not news. */
	if (strstr(msg, "no longer available for sending"))
		return;
	fprintf(stderr, "mocap-preview: http: %s", msg);
}

preview_http *http_start(int listen_fd, const http_config *cfg, mc_err *err)
{
	preview_http *h = calloc(1, sizeof(*h));
	if (!h) {
		close(listen_fd);
		mc_err_set(err, "out of memory");
		return NULL;
	}
	h->cfg = *cfg;
	if (!(h->guard = guard_new())) {
		close(listen_fd);
		free(h);
		mc_err_set(err, "out of memory");
		return NULL;
	}
	/* A thread per connection: an event stream blocks in its reader
	 * callback until there is something new.  The guard bounds what the
	 * options below do not (preview_guard.h). */
	h->mhd = MHD_start_daemon(MHD_USE_THREAD_PER_CONNECTION | MHD_USE_INTERNAL_POLLING_THREAD | MHD_USE_ERROR_LOG, 0,
				  NULL, NULL, on_request, h, MHD_OPTION_EXTERNAL_LOGGER, log_mhd, NULL,
				  MHD_OPTION_LISTEN_SOCKET, listen_fd,
				  MHD_OPTION_CONNECTION_LIMIT, 64u, MHD_OPTION_PER_IP_CONNECTION_LIMIT, 32u,
				  MHD_OPTION_CONNECTION_TIMEOUT, 60u, MHD_OPTION_NOTIFY_CONNECTION, guard_notify_connection,
				  h->guard, MHD_OPTION_NOTIFY_COMPLETED, guard_request_completed, h->guard, MHD_OPTION_END);
	if (!h->mhd) {
		close(listen_fd);
		guard_free(h->guard);
		free(h);
		mc_err_set(err, "cannot start the HTTP server (libmicrohttpd)");
		return NULL;
	}
	return h;
}

void http_stop(preview_http *h)
{
	if (!h)
		return;
	MHD_stop_daemon(h->mhd);
	guard_free(h->guard);
	free(h);
}
