/* The message for a socket this user may not open: connect() says only
 * EACCES, and "permission denied" leaves the user guessing which group to
 * join (issue 31).  The socket's group and mode, or those of the folder
 * that cannot be entered, say it. */
#include "client/internal.h"

#include <errno.h>
#include <grp.h>
#include <pwd.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

static void group_name(gid_t gid, char *out, size_t cap)
{
	char buf[4096];
	struct group g, *found = NULL;
	if (getgrgid_r(gid, &g, buf, sizeof(buf), &found) == 0 && found)
		snprintf(out, cap, "%s", found->gr_name);
	else
		snprintf(out, cap, "%u", (unsigned)gid);
}

static void user_name(uid_t uid, char *out, size_t cap)
{
	char buf[4096];
	struct passwd p, *found = NULL;
	if (getpwuid_r(uid, &p, buf, sizeof(buf), &found) == 0 && found)
		snprintf(out, cap, "%s", found->pw_name);
	else
		snprintf(out, cap, "%u", (unsigned)uid);
}

void mcl_access_message(char *out, size_t cap, const char *path, const char *what, const struct stat *st)
{
	int mode = (int)(st->st_mode & 07777);
	char group[256], owner[256];
	group_name(st->st_gid, group, sizeof(group));
	user_name(st->st_uid, owner, sizeof(owner));
	/* Without group access, joining the group would not help. */
	bool group_may = S_ISDIR(st->st_mode) ? (st->st_mode & S_IXGRP) != 0 : (st->st_mode & S_IWGRP) != 0;
	if (group_may)
		snprintf(out, cap,
			 "permission denied connecting to %s: %s belongs to group %s (mode %04o) and your user is not "
			 "in it: sudo usermod -aG %s $USER, then log in again (or newgrp %s in one shell)",
			 path, what, group, mode, group, group);
	else
		snprintf(out, cap,
			 "permission denied connecting to %s: %s belongs to user %s, group %s, with mode %04o: only "
			 "its owner may connect (the daemon's [socket] mode sets it)",
			 path, what, owner, group, mode);
}

int mcl_access_error(const char *path)
{
	char msg[MCL_ERRMSG_MAX];
	struct stat st;
	if (stat(path, &st) == 0) {
		mcl_access_message(msg, sizeof(msg), path, "the socket", &st);
		return mcl_set_err(MOCAP_E_ACCESS, "%s", msg);
	}
	/* The socket cannot even be looked at: its folder (/run/mocapd is
	 * the daemon's, mode 0750) keeps this user out. */
	char dir[sizeof(((struct sockaddr_un *)0)->sun_path) + 1];
	snprintf(dir, sizeof(dir), "%s", path);
	char *slash = strrchr(dir, '/');
	if (slash)
		*(slash == dir ? slash + 1 : slash) = 0;
	char what[sizeof(dir) + 16];
	snprintf(what, sizeof(what), "its folder %s", dir);
	if (slash && stat(dir, &st) == 0) {
		mcl_access_message(msg, sizeof(msg), path, what, &st);
		return mcl_set_err(MOCAP_E_ACCESS, "%s", msg);
	}
	return mcl_set_err(MOCAP_E_ACCESS, "permission denied connecting to %s: your user needs to be in the daemon's "
			   "group", path);
}
