/* A minimal Chrome DevTools Protocol client for the browser test: runs
 * headless Chromium with --remote-debugging-pipe (commands on its fd 3,
 * replies and events on its fd 4, JSON messages ending in a NUL byte), so
 * that no WebSocket is needed.  Records the URL of every request the page
 * makes (Network.requestWillBeSent), and the page's exceptions and console
 * errors (a Content-Security-Policy violation is one). */
#ifndef PREVIEW_CDP_H
#define PREVIEW_CDP_H

#include "daemon/harness.h"

#include <jansson.h>

typedef struct {
	pid_t pid;
	int to, from; /* our ends of its fd 3 and fd 4 */
	char *buf;
	size_t len, cap;
	int next_id;
	json_t *urls; /* every request's URL */
	json_t *errors; /* exceptions thrown in the page, and console errors */
} cdp;

/* Moves fd to a descriptor number above 10 (so that dup2 onto 3 and 4
 * cannot clobber it). */
static inline int cdp_high_fd(int fd)
{
	int h = fcntl(fd, F_DUPFD, 10);
	close(fd);
	return h;
}

static inline bool cdp_start(cdp *c, const char *chromium, const char *const *args, const char *log)
{
	memset(c, 0, sizeof(*c));
	int in[2], out[2];
	if (pipe(in) != 0 || pipe(out) != 0)
		return false;
	c->urls = json_array();
	c->errors = json_array();
	c->pid = fork();
	if (c->pid == 0) {
		int r = cdp_high_fd(in[0]), w = cdp_high_fd(out[1]);
		close(in[1]);
		close(out[0]);
		int fd = open(log, O_WRONLY | O_CREAT | O_TRUNC, 0644);
		dup2(fd, 1);
		dup2(fd, 2);
		dup2(r, 3);
		dup2(w, 4);
		const char *argv[48] = {chromium};
		int n = 1;
		for (int i = 0; args[i] && n < 47; i++)
			argv[n++] = args[i];
		argv[n] = NULL;
		execv(chromium, (char *const *)argv);
		_exit(127);
	}
	close(in[0]);
	close(out[1]);
	c->to = in[1];
	c->from = out[0];
	fcntl(c->to, F_SETFD, FD_CLOEXEC);
	fcntl(c->from, F_SETFD, FD_CLOEXEC);
	return c->pid > 0;
}

/* The next whole message, waiting up to ms; NULL on timeout or EOF. */
static inline json_t *cdp_next(cdp *c, int ms)
{
	uint64_t end = mcd_now_ms() + (uint64_t)ms;
	for (;;) {
		char *nul = c->len ? memchr(c->buf, 0, c->len) : NULL;
		if (nul) {
			size_t n = (size_t)(nul - c->buf);
			json_t *m = json_loadb(c->buf, n, 0, NULL);
			memmove(c->buf, nul + 1, c->len - n - 1);
			c->len -= n + 1;
			return m ? m : json_object();
		}
		uint64_t now = mcd_now_ms();
		if (now >= end)
			return NULL;
		struct pollfd p = {.fd = c->from, .events = POLLIN};
		if (poll(&p, 1, (int)(end - now)) <= 0)
			return NULL;
		if (c->len + 65536 > c->cap) {
			c->cap = (c->len + 65536) * 2;
			c->buf = realloc(c->buf, c->cap);
		}
		ssize_t r = read(c->from, c->buf + c->len, 65536);
		if (r <= 0)
			return NULL;
		c->len += (size_t)r;
	}
}

/* Notes the events this test cares about. */
static inline void cdp_event(cdp *c, json_t *m)
{
	const char *method = json_string_value(json_object_get(m, "method"));
	json_t *params = json_object_get(m, "params");
	if (method && !strcmp(method, "Network.requestWillBeSent")) {
		json_t *url = json_object_get(json_object_get(params, "request"), "url");
		if (json_is_string(url))
			json_array_append(c->urls, url);
	} else if (method && !strcmp(method, "Runtime.exceptionThrown")) {
		json_array_append(c->errors, json_object_get(params, "exceptionDetails"));
	} else if (method && !strcmp(method, "Log.entryAdded")) {
		json_t *entry = json_object_get(params, "entry");
		if (!strcmp(json_string_value(json_object_get(entry, "level")) ?: "", "error"))
			json_array_append(c->errors, entry);
	}
}

/* Sends a command (params is taken) and waits for its reply: the result
 * (a new reference) or NULL, with the error printed. */
static inline json_t *cdp_call(cdp *c, const char *session, const char *method, json_t *params, int ms)
{
	int id = ++c->next_id;
	json_t *msg = json_pack("{s:i, s:s, s:o}", "id", id, "method", method, "params", params ? params : json_object());
	if (session)
		json_object_set_new(msg, "sessionId", json_string(session));
	char *text = json_dumps(msg, JSON_COMPACT);
	json_decref(msg);
	size_t n = strlen(text) + 1; /* with the NUL */
	bool sent = write(c->to, text, n) == (ssize_t)n;
	free(text);
	if (!sent)
		return NULL;
	uint64_t end = mcd_now_ms() + (uint64_t)ms;
	for (;;) {
		uint64_t now = mcd_now_ms();
		json_t *m = now < end ? cdp_next(c, (int)(end - now)) : NULL;
		if (!m) {
			fprintf(stderr, "cdp: %s: no reply\n", method);
			return NULL;
		}
		if (json_integer_value(json_object_get(m, "id")) == id) {
			json_t *res = json_incref(json_object_get(m, "result"));
			if (!res) {
				char *e = json_dumps(json_object_get(m, "error"), JSON_COMPACT);
				fprintf(stderr, "cdp: %s: %s\n", method, e ? e : "?");
				free(e);
			}
			json_decref(m);
			return res;
		}
		cdp_event(c, m);
		json_decref(m);
	}
}

/* Runtime.evaluate of an expression in the page, its value (JSON) or NULL. */
static inline json_t *cdp_eval(cdp *c, const char *session, const char *expr)
{
	json_t *res = cdp_call(c, session, "Runtime.evaluate",
			       json_pack("{s:s, s:b, s:b}", "expression", expr, "returnByValue", 1, "awaitPromise", 1), 20000);
	json_t *v = json_incref(json_object_get(json_object_get(res, "result"), "value"));
	json_decref(res);
	return v;
}

static inline int cdp_close(cdp *c)
{
	json_decref(cdp_call(c, NULL, "Browser.close", NULL, 5000));
	close(c->to);
	close(c->from);
	int rc = mcd_wait_pid(c->pid, 15000);
	free(c->buf);
	json_decref(c->urls);
	json_decref(c->errors);
	return rc;
}

#endif
