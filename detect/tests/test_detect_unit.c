/* systemd/mocap-detect.service: `systemd-analyze verify` on the unit as
 * `make install` writes it (pointing at the built mocap-detect), its
 * hardening score (`systemd-analyze security --offline`, at most 1.0) and
 * the settings that make it a client of mocapd.  Skips when systemd's tools
 * are missing. */
#include "test_util.h"

#include <limits.h>
#include <stdbool.h>
#include <string.h>
#include <unistd.h>

static char scratch[64];
static char build_dir[PATH_MAX];

static bool find_build(void)
{
	if (!mc_test_build_dir(3, build_dir, sizeof(build_dir))) /* <build>/detect/tests/test_detect_unit */
		return false;
	char bin[PATH_MAX + 32];
	snprintf(bin, sizeof(bin), "%s/bin/mocap-detect", build_dir);
	return access(bin, X_OK) == 0;
}

static char *read_text(const char *path)
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

int main(void)
{
	char cmd[PATH_MAX * 2 + 512], out[32768];
	if (access("systemd/mocap-detect.service", R_OK) != 0)
		TEST_SKIP("run from the repository root (systemd/mocap-detect.service not found)");
	if (mc_test_run("command -v systemd-analyze 2>&1", out, sizeof(out)) != 0)
		TEST_SKIP("systemd-analyze is not installed (Debian package systemd)");
	if (!find_build())
		TEST_SKIP("mocap-detect is not built (the unit's ExecStart must exist for verify)");
	snprintf(scratch, sizeof(scratch), "/tmp/mocap-detect-unit-XXXXXX");
	if (!mkdtemp(scratch))
		TEST_SKIP("cannot create a scratch directory");

	const char *unit = read_text("systemd/mocap-detect.service");
	static const char *const want[] = {
		"After=mocapd.socket mocapd.service\n", "PartOf=mocapd.service\n", "SupplementaryGroups=mocapd\n",
		"--socket /run/mocapd/mocapd.sock",     "Restart=on-failure\n",    "RestrictAddressFamilies=AF_UNIX\n",
		"WantedBy=mocapd.service\n",
	};
	for (size_t i = 0; i < sizeof(want) / sizeof(want[0]); i++)
		CHECK_MSG(unit && strstr(unit, want[i]), "mocap-detect.service lacks %s", want[i]);

	snprintf(cmd, sizeof(cmd),
		 "sed -e 's|@BINDIR@|%s/bin|g' -e 's|@DOCDIR@|/usr/share/doc/mocapd|g' systemd/mocap-detect.service "
		 "> %s/mocap-detect.service 2>&1",
		 build_dir, scratch);
	CHECK_MSG(mc_test_run(cmd, out, sizeof(out)) == 0, "%s", out);
	snprintf(cmd, sizeof(cmd), "cd %s && systemd-analyze verify ./mocap-detect.service 2>&1", scratch);
	int rc = mc_test_run(cmd, out, sizeof(out));
	CHECK_MSG(rc == 0, "systemd-analyze verify: exit %d:\n%s", rc, out);
	CHECK_MSG(!strstr(out, "mocap-detect.service:"), "warnings:\n%s", out);

	snprintf(cmd, sizeof(cmd), "cd %s && systemd-analyze security --offline=true ./mocap-detect.service 2>&1",
		 scratch);
	rc = mc_test_run(cmd, out, sizeof(out));
	const char *line = strstr(out, "Overall exposure level for mocap-detect.service:");
	if (rc != 0 && !line)
		printf("systemd-analyze security --offline cannot run here (exit %d); score not checked\n", rc);
	else {
		double score = 99;
		CHECK_MSG(line && sscanf(line, "Overall exposure level for mocap-detect.service: %lf", &score) == 1,
			  "%s", out);
		printf("systemd-analyze security: exposure %.1f\n", score);
		CHECK_MSG(score <= 1.0, "exposure %.1f > 1.0: hardening regressed", score);
	}
	snprintf(cmd, sizeof(cmd), "rm -rf %s", scratch);
	mc_test_run(cmd, out, sizeof(out));
	return mc_test_finish("test_detect_unit");
}
