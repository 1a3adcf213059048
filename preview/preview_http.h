/* preview_http: mocap-preview's HTTP server (libmicrohttpd, a thread per
 * connection).
 *
 *   GET  /                      the page (www/index.html), /preview.js, /preview.css
 *   GET  /three/three.min.js    three.js from Debian's libjs-three, and
 *   GET  /three/OrbitControls.js   its orbit controls: nothing from the network
 *   GET  /events                Server-Sent Events: status, skeleton, frame
 *   POST /api/record/start[?name=NAME], /api/record/stop, /api/reload
 *                               state changes: need the token in the
 *                               X-Mocap-Token header, else 403
 *
 * Reading is open to whoever reaches the address (127.0.0.1 by default);
 * changing state needs the token.  On a loopback address the Host header
 * must name the loopback too, so that a web page elsewhere cannot read the
 * cameras through DNS rebinding. */
#ifndef PREVIEW_HTTP_H
#define PREVIEW_HTTP_H

#include "base/mc_error.h"
#include "mocap.h"
#include "preview_hub.h"

#include <stdbool.h>
#include <stddef.h>

/* Runs a control request in the daemon: 0 or a MOCAP_E_* code, msg gets
 * the daemon's message. */
typedef int (*http_control_fn)(void *ctx, mocap_command cmd, const char *argument, char *msg, size_t cap);

typedef struct {
	const char *www_dir;   /* index.html, preview.js, preview.css */
	const char *three_dir; /* three.min.js, examples/js/controls/OrbitControls.js */
	const char *token;     /* for state changes */
	bool loopback;         /* listening on a loopback address: check Host */
	int port;
	preview_hub *hub;
	http_control_fn control;
	void *control_ctx;
} http_config;

typedef struct preview_http preview_http;

/* Serves on listen_fd (bound and listening; the server closes it). */
preview_http *http_start(int listen_fd, const http_config *cfg, mc_err *err);
void http_stop(preview_http *h);

/* True when token equals the expected one, in time independent of where
 * they differ. */
bool http_token_ok(const char *expected, const char *given);
/* A take name a page may ask for: 1..64 of [A-Za-z0-9._-], not starting
 * with a dot (no paths: where takes go is the daemon's business). */
bool http_take_name_ok(const char *name);

#endif
