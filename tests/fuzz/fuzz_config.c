/* libFuzzer target: mocapd's INI configuration (daemon/config.c, inih),
 * parsed from text as mcd_config_load does after reading the file.
 * Besides "no crash, no leak, no undefined behaviour": a refused file gets
 * a message that starts with the file's name, and an accepted one is
 * consistent with the checks across keys (at least one camera, each with
 * a driver).  The same text is parsed again collecting every error
 * (mcd_config_parse_all, mocapd --check): it must agree on acceptance and
 * on the first error, and keep its list within its buffer. */
#include "config.h"
#include "fuzz_util.h"

#include <stdlib.h>
#include <string.h>

#define ORIGIN "fuzz.conf"

static mcd_config *cfg; /* large (the key table): allocated once */

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	if (!cfg && !(cfg = calloc(1, sizeof(*cfg))))
		abort();
	char *text = fuzz_text(data, size);
	mc_err err = {{0}}, err_all = {{0}};
	static char list[2048];
	mcd_config_errors all = {.buf = list, .cap = sizeof(list)};
	list[0] = 0;
	memset(cfg, 0, sizeof(*cfg));
	int rc_all = mcd_config_parse_all(text, ORIGIN, "/nonexistent", cfg, &all, &err_all);
	if (rc_all != 0 && (all.n < 1 || all.len >= sizeof(list) || strlen(list) != all.len))
		fuzz_fail("fuzz_config", "parse_all refused without a consistent error list", &err_all);
	memset(cfg, 0, sizeof(*cfg));
	int rc = mcd_config_parse(text, ORIGIN, "/nonexistent", cfg, &err);
	if (rc != rc_all || (rc && strcmp(err.msg, err_all.msg) != 0))
		fuzz_fail("fuzz_config", "parse and parse_all disagree", &err);
	if (rc != 0) {
		fuzz_check_refusal("fuzz_config", ORIGIN, &err);
	} else {
		if (cfg->ncams < 1 || cfg->ncams > MC_MAX_CAMERAS)
			fuzz_fail("fuzz_config", "accepted a config with no camera or too many", NULL);
		for (int i = 0; i < cfg->ncams; i++)
			if (!cfg->cams[i].driver[0] || cfg->cams[i].nkeys > MCD_MAX_DRIVER_KEYS)
				fuzz_fail("fuzz_config", "accepted a camera without a driver or with too many keys", NULL);
		char where[400];
		mcd_config_where(cfg, "tracker", "rig", where, sizeof(where));
	}
	free(text);
	return 0;
}
