/* systemd/mocap-vmc.service: `systemd-analyze verify` on the unit as `make
 * install` writes it (pointing at the built mocap-vmc), its hardening score
 * (`systemd-analyze security --offline`) and the settings that make it a
 * client of mocapd sending UDP (tests/unit_check.h).  Its exposure is
 * allowed a little more than mocap-detect's: it needs IP sockets. */
#include "unit_check.h"

int main(void)
{
	static const char *const want[] = {
		"After=mocapd.socket mocapd.service",
		"PartOf=mocapd.service\n",
		"SupplementaryGroups=mocapd\n",
		"--socket /run/mocapd/mocapd.sock",
		"--config @SYSCONFDIR@/mocapd/vmc.conf",
		"Restart=on-failure\n",
		"RestartPreventExitStatus=2\n",
		"RestrictAddressFamilies=AF_UNIX AF_INET AF_INET6\n",
		"WantedBy=mocapd.service\n",
		NULL,
	};
	mc_check_client_unit("mocap-vmc", 3, want, 2.0); /* <build>/vmc/tests/test_vmc_unit */
	return mc_test_finish("test_vmc_unit");
}
