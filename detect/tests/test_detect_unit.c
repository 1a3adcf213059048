/* systemd/mocap-detect.service: `systemd-analyze verify` on the unit as
 * `make install` writes it (pointing at the built mocap-detect), its
 * hardening score (`systemd-analyze security --offline`, at most 1.0) and
 * the settings that make it a client of mocapd (tests/unit_check.h). */
#include "unit_check.h"

int main(void)
{
	static const char *const want[] = {
		"After=mocapd.socket mocapd.service\n", "PartOf=mocapd.service\n", "SupplementaryGroups=mocapd\n",
		"--socket /run/mocapd/mocapd.sock",     "Restart=on-failure\n",    "RestrictAddressFamilies=AF_UNIX\n",
		"WantedBy=mocapd.service\n",            NULL,
	};
	mc_check_client_unit("mocap-detect", 3, want, 1.0); /* <build>/detect/tests/test_detect_unit */
	return mc_test_finish("test_detect_unit");
}
