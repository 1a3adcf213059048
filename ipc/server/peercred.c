/* Peer credentials: who is at the other end of a connection (SO_PEERCRED,
 * taken at connect time by the kernel, so a client cannot lie about it)
 * and whether that makes it privileged: the daemon's own user, root, or a
 * member of the control group (primary or supplementary, SO_PEERGROUPS). */
#include "server/internal.h"

#include <sys/socket.h>
#include <unistd.h>

#define MAX_PEER_GROUPS 256

static bool in_group_list(const gid_t *groups, int n, gid_t g)
{
	for (int i = 0; i < n; i++)
		if (groups[i] == g)
			return true;
	return false;
}

/* The daemon's user, root, or a member of the control group. */
static bool peer_is_privileged(const srv_server *srv, int fd, const struct ucred *cr)
{
	if (cr->uid == 0 || cr->uid == geteuid())
		return true;
	gid_t g = srv->cfg.control_gid == (gid_t)-1 ? getegid() : srv->cfg.control_gid;
	if (cr->gid == g)
		return true;
	gid_t groups[MAX_PEER_GROUPS];
	socklen_t len = sizeof(groups);
	if (getsockopt(fd, SOL_SOCKET, SO_PEERGROUPS, groups, &len) == 0)
		return in_group_list(groups, (int)(len / sizeof(gid_t)), g);
	return false;
}

bool srv_peer_identify(const srv_server *srv, int fd, client *c)
{
	struct ucred cr;
	socklen_t l = sizeof(cr);
	if (getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cr, &l) != 0)
		return false;
	c->pid = cr.pid;
	c->uid = cr.uid;
	c->gid = cr.gid;
	c->privileged = peer_is_privileged(srv, fd, &cr);
	return true;
}
