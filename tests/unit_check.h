/* Checks a systemd unit of a mocapd client (mocap-detect, mocap-vmc) as
 * `make install` writes it: `systemd-analyze verify` with ExecStart
 * pointing at the built binary, the hardening score (`systemd-analyze
 * security --offline`, at most max_exposure) and the lines it must have.
 * Skips when systemd's tools are missing or the binary is not built. */
#ifndef MC_UNIT_CHECK_H
#define MC_UNIT_CHECK_H

#include "test_util.h"

#include <limits.h>
#include <stdbool.h>
#include <string.h>
#include <unistd.h>

static inline const char *mc_unit_read(const char *path)
{
	FILE *f = fopen(path, "rb");
	if (!f)
		return NULL;
	static char buf[16384];
	size_t n = fread(buf, 1, sizeof(buf) - 1, f);
	buf[n] = 0;
	fclose(f);
	return buf;
}

/* unit: e.g. "mocap-vmc" (systemd/<unit>.service, <build>/bin/<unit>);
 * build_up: how many folders the test program sits below the build
 * folder. */
static inline void mc_check_client_unit(const char *unit, int build_up, const char *const *want, double max_exposure)
{
	char src[256], bin[PATH_MAX + 64], build_dir[PATH_MAX], scratch[64], cmd[PATH_MAX * 2 + 512];
	static char out[32768];
	snprintf(src, sizeof(src), "systemd/%s.service", unit);
	if (access(src, R_OK) != 0)
		TEST_SKIP("run from the repository root (%s not found)", src);
	if (mc_test_run("command -v systemd-analyze 2>&1", out, sizeof(out)) != 0)
		TEST_SKIP("systemd-analyze is not installed (Debian package systemd)");
	if (!mc_test_build_dir(build_up, build_dir, sizeof(build_dir)))
		TEST_SKIP("cannot find the build folder");
	snprintf(bin, sizeof(bin), "%s/bin/%s", build_dir, unit);
	if (access(bin, X_OK) != 0)
		TEST_SKIP("%s is not built (the unit's ExecStart must exist for verify)", bin);
	snprintf(scratch, sizeof(scratch), "/tmp/%s-unit-XXXXXX", unit);
	if (!mkdtemp(scratch))
		TEST_SKIP("cannot create a scratch directory");

	const char *text = mc_unit_read(src);
	for (int i = 0; want[i]; i++)
		CHECK_MSG(text && strstr(text, want[i]), "%s lacks %s", src, want[i]);

	snprintf(cmd, sizeof(cmd),
		 "sed -e 's|@BINDIR@|%s/bin|g' -e 's|@DOCDIR@|/usr/share/doc/mocapd|g' -e 's|@SYSCONFDIR@|/etc|g' %s "
		 "> %s/%s.service 2>&1",
		 build_dir, src, scratch, unit);
	CHECK_MSG(mc_test_run(cmd, out, sizeof(out)) == 0, "%s", out);
	/* --man=no: the units name their man pages, which a build tree has
	 * not installed (the package tests check them there) */
	snprintf(cmd, sizeof(cmd), "cd %s && systemd-analyze verify --man=no ./%s.service 2>&1", scratch, unit);
	int rc = mc_test_run(cmd, out, sizeof(out));
	CHECK_MSG(rc == 0, "systemd-analyze verify: exit %d:\n%s", rc, out);
	char own[128];
	snprintf(own, sizeof(own), "%s.service:", unit);
	CHECK_MSG(!strstr(out, own), "warnings:\n%s", out);

	snprintf(cmd, sizeof(cmd), "cd %s && systemd-analyze security --offline=true ./%s.service 2>&1", scratch, unit);
	rc = mc_test_run(cmd, out, sizeof(out));
	char label[160];
	snprintf(label, sizeof(label), "Overall exposure level for %s.service:", unit);
	const char *line = strstr(out, label);
	if (rc != 0 && !line)
		printf("systemd-analyze security --offline cannot run here (exit %d); score not checked\n", rc);
	else {
		double score = 99;
		CHECK_MSG(line && sscanf(line + strlen(label), "%lf", &score) == 1, "%s", out);
		printf("systemd-analyze security: %s exposure %.1f\n", unit, score);
		CHECK_MSG(score <= max_exposure, "exposure %.1f > %.1f: hardening regressed", score, max_exposure);
	}
	snprintf(cmd, sizeof(cmd), "rm -rf %s", scratch);
	mc_test_run(cmd, out, sizeof(out));
}

#endif
