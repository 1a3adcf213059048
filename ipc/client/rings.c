/* Camera rings: read-only descriptors of the daemon's frame rings, passed
 * with the RINGS reply (SCM_RIGHTS).  Privileged clients only. */
#include "client/internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

int mocap_get_rings(mocap_client *c, mocap_ring *rings, int max)
{
	proto_msg *m = mcl_new_msg(MC_MSG_GET_RINGS);
	if (!m)
		return MOCAP_E_SYSTEM;
	int fds[MAX_RX_FDS], nfds = 0;
	int rc = mcl_request(c, m, MC_MSG_RINGS, m, fds, &nfds, NULL);
	if (rc == 0) {
		if (nfds != m->u.rings.count) {
			mcl_close_fds(fds, nfds);
			rc = mcl_set_err(MOCAP_E_PROTOCOL, "RINGS lists %u rings but came with %d descriptors",
					 m->u.rings.count, nfds);
		} else {
			int n = 0;
			for (int i = 0; i < nfds; i++) {
				if (n >= max) {
					close(fds[i]);
					continue;
				}
				snprintf(rings[n].camera, sizeof(rings[n].camera), "%s", m->u.rings.rings[i].name);
				rings[n].fd = fds[i];
				rings[n].size = m->u.rings.rings[i].size;
				n++;
			}
			rc = n;
		}
	}
	free(m);
	return rc;
}
