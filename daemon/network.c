/* network: [network] listen, token_file and privileged for the socket
 * server.  The token is a secret: it is read from its own file (which may
 * be 0600 while the config is world-readable) and refused when anyone
 * may read it. */
#include "network.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

static int token_error(const mcd_config *cfg, mc_err *err, const char *fmt, const char *detail)
{
	char where[700], why[512];
	snprintf(why, sizeof(why), fmt, detail);
	return mc_err_set(err, "%s: %s: %s", mcd_config_where(cfg, "network", "token_file", where, sizeof(where)),
			  cfg->network.token_file, why);
}

int mcd_network_read_token(const mcd_config *cfg, char *out, size_t cap, mc_err *err)
{
	FILE *f = fopen(cfg->network.token_file, "r");
	if (!f)
		return token_error(cfg, err, "%s", strerror(errno));
	struct stat st;
	if (fstat(fileno(f), &st) == 0 && (st.st_mode & S_IROTH)) {
		fclose(f);
		return token_error(cfg, err, "%s", "readable by every user; make it private (chmod 600 or 640)");
	}
	char line[SRV_TOKEN_MAX + 2];
	bool got = fgets(line, sizeof(line), f) != NULL;
	fclose(f);
	size_t n = got ? strcspn(line, "\r\n") : 0;
	line[n] = 0;
	if (n < SRV_TOKEN_MIN || n >= cap || n >= SRV_TOKEN_MAX) {
		char range[64];
		snprintf(range, sizeof(range), "%d to %d", SRV_TOKEN_MIN, SRV_TOKEN_MAX - 1);
		return token_error(cfg, err, "the token (its first line) must have %s characters", range);
	}
	memcpy(out, line, n + 1);
	return 0;
}

int mcd_network_apply(const mcd_config *cfg, srv_config *sc, mc_err *err)
{
	const mcd_network_config *n = &cfg->network;
	if (!n->listen[0])
		return 0;
	if (mcd_network_read_token(cfg, sc->tcp_token, sizeof(sc->tcp_token), err))
		return -1;
	snprintf(sc->tcp_listen, sizeof(sc->tcp_listen), "%s", n->listen);
	sc->tcp_privileged = n->privileged;
	return 0;
}
