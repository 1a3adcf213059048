/* preview_guard: limits for mocap-preview's HTTP connections that
 * libmicrohttpd's own (a connection count, a per-address count, an idle
 * timeout) do not give (issue 34 item 2):
 *   - a request's headers must be whole within GUARD_HEADER_S of the
 *     connection (or of the previous request on it): a header line every
 *     20 s kept resetting the idle timeout, so 64 such connections held
 *     the server;
 *   - at most GUARD_MAX_PENDING connections may be waiting for their
 *     headers, so that the rest of the connection limit stays for pages:
 *     past it, the one that has waited longest (over 0.5 s) is closed,
 *     else the new one;
 *   - at most GUARD_MAX_STREAMS event streams at once; a stream that does
 *     not read is closed after GUARD_STREAM_IDLE_S without progress.
 * A connection over a limit is shut down (the server then closes it); a
 * stream over the limit gets 503. */
#ifndef PREVIEW_GUARD_H
#define PREVIEW_GUARD_H

#include <microhttpd.h>
#include <stdbool.h>

#define GUARD_HEADER_S 10
#define GUARD_MAX_PENDING 32
#define GUARD_MAX_STREAMS 16
#define GUARD_STREAM_IDLE_S 25 /* an idle stream gets a keep-alive every 10 s */

typedef struct preview_guard preview_guard;

/* NULL when out of memory or the watchdog thread does not start. */
preview_guard *guard_new(void);
/* After MHD_stop_daemon: every connection is closed by then. */
void guard_free(preview_guard *g);

/* MHD_OPTION_NOTIFY_CONNECTION and MHD_OPTION_NOTIFY_COMPLETED callbacks
 * (cls: the guard). */
void guard_notify_connection(void *cls, struct MHD_Connection *conn, void **socket_context,
			     enum MHD_ConnectionNotificationCode toe);
void guard_request_completed(void *cls, struct MHD_Connection *conn, void **con_cls,
			     enum MHD_RequestTerminationCode toe);

/* A request's headers are whole (the first call of the request handler). */
void guard_headers_done(preview_guard *g, struct MHD_Connection *conn);
/* An event stream starts on conn: false when GUARD_MAX_STREAMS are open. */
bool guard_stream_begin(preview_guard *g, struct MHD_Connection *conn);
void guard_stream_end(preview_guard *g);

#endif
