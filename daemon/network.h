/* network: the [network] section's TCP listener for clients on other
 * machines, turned into the socket server's settings (ipc/server.h). */
#ifndef MCD_NETWORK_H
#define MCD_NETWORK_H

#include "config.h"
#include "server.h"

/* Reads the access token of [network] token_file into out: its first
 * line, SRV_TOKEN_MIN to SRV_TOKEN_MAX - 1 bytes.  The file must not be
 * readable by every user.  Errors name the file and the config line. */
int mcd_network_read_token(const mcd_config *cfg, char *out, size_t cap, mc_err *err);

/* Sets sc's TCP listener, token and privilege from [network]; nothing when
 * listen is not given.  0, or -1 with err set. */
int mcd_network_apply(const mcd_config *cfg, srv_config *sc, mc_err *err);

#endif
