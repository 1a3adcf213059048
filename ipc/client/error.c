/* Errors: per thread, like errno.  Every failing mocap_ call sets a code
 * and a message for the user; the connection's own fatal error (the
 * daemon stopped, or closed us) is kept in the client and repeated by
 * every later call. */
#include "client/internal.h"

#include <stdarg.h>
#include <stdio.h>

static _Thread_local int tl_code;
static _Thread_local char tl_msg[MCL_ERRMSG_MAX];

int mcl_set_err(int code, const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(tl_msg, sizeof(tl_msg), fmt, ap);
	va_end(ap);
	tl_code = code;
	return code;
}

int mocap_errcode(void) { return tl_code; }
const char *mocap_errmsg(void) { return tl_msg[0] ? tl_msg : mocap_strerror(tl_code); }

int mcl_dead_error(mocap_client *c) { return mcl_set_err(c->dead, "%s", c->dead_msg); }

const char *mocap_strerror(int code)
{
	switch (code) {
	case 0: return "no error";
	case MOCAP_E_NOT_RUNNING: return "daemon not running";
	case MOCAP_E_ACCESS: return "permission denied on the socket";
	case MOCAP_E_VERSION: return "protocol version mismatch";
	case MOCAP_E_PROTOCOL: return "protocol error";
	case MOCAP_E_DISCONNECTED: return "disconnected";
	case MOCAP_E_TIMEOUT: return "timed out";
	case MOCAP_E_PERMISSION: return "not allowed";
	case MOCAP_E_REFUSED: return "refused by the daemon";
	case MOCAP_E_UNAVAILABLE: return "not available";
	case MOCAP_E_FAILED: return "command failed";
	case MOCAP_E_ARG: return "invalid argument";
	case MOCAP_E_SYSTEM: return "system error";
	}
	return "unknown error";
}

const char *mocap_track_state_name(mocap_track_state s)
{
	switch (s) {
	case MOCAP_TRACK_OK: return "ok";
	case MOCAP_TRACK_UNCERTAIN: return "uncertain";
	case MOCAP_TRACK_LOST: return "lost";
	case MOCAP_TRACK_IDLE: return "idle";
	case MOCAP_TRACK_INITIALISING: return "initialising";
	}
	return "unknown";
}

int mcl_code_of_server_error(uint32_t code)
{
	switch (code) {
	case PROTO_E_VERSION: return MOCAP_E_VERSION;
	case PROTO_E_MALFORMED:
	case PROTO_E_HANDSHAKE: return MOCAP_E_PROTOCOL;
	case PROTO_E_PERMISSION: return MOCAP_E_PERMISSION;
	case PROTO_E_AUTH: return MOCAP_E_ACCESS;
	case PROTO_E_UNAVAILABLE: return MOCAP_E_UNAVAILABLE;
	case PROTO_E_SHUTDOWN: return MOCAP_E_DISCONNECTED;
	}
	return MOCAP_E_REFUSED;
}
