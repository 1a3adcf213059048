/* The message of a client the socket's permissions keep out (issue 31):
 * it names the socket's group and mode (or its folder's, when the folder
 * keeps the user out) and how to join that group, or says that only the
 * owner may connect when the group has no access either.
 *
 * mcl_access_message is checked on stat results made up here; the real
 * path (connect() refused with EACCES, the stat, the message) as user
 * nobody in a child, since root connects to any socket. */
#include "client/internal.h"
#include "mocap.h"
#include "test_util.h"

#include <grp.h>
#include <sys/socket.h>
#include <sys/un.h>

static bool says(const char *msg, const char *part)
{
	bool ok = strstr(msg, part) != NULL;
	if (!ok)
		fprintf(stderr, "the message does not say \"%s\": %s\n", part, msg);
	return ok;
}

static void test_message(void)
{
	char msg[MCL_ERRMSG_MAX];
	struct stat st = {.st_mode = S_IFSOCK | 0660, .st_uid = 0, .st_gid = 0};
	mcl_access_message(msg, sizeof(msg), "/run/mocapd/mocapd.sock", "the socket", &st);
	printf("0660: %s\n", msg);
	CHECK(says(msg, "permission denied connecting to /run/mocapd/mocapd.sock: "));
	CHECK(says(msg, "the socket belongs to group root (mode 0660)"));
	CHECK(says(msg, "sudo usermod -aG root $USER, then log in again"));

	/* A group without a name is given by number. */
	st.st_gid = 4000123;
	mcl_access_message(msg, sizeof(msg), "/s", "the socket", &st);
	CHECK(getgrgid(4000123) != NULL || says(msg, "group 4000123 (mode 0660)"));

	/* The group may not connect either: joining it would not help. */
	st = (struct stat){.st_mode = S_IFSOCK | 0600, .st_uid = 0, .st_gid = 0};
	mcl_access_message(msg, sizeof(msg), "/s", "the socket", &st);
	printf("0600: %s\n", msg);
	CHECK(says(msg, "user root, group root, with mode 0600: only its owner may connect"));
	CHECK(!strstr(msg, "usermod"));

	/* A folder needs search (x) for the group. */
	st = (struct stat){.st_mode = S_IFDIR | 0750, .st_gid = 0};
	mcl_access_message(msg, sizeof(msg), "/run/mocapd/mocapd.sock", "its folder /run/mocapd", &st);
	printf("folder: %s\n", msg);
	CHECK(says(msg, "its folder /run/mocapd belongs to group root (mode 0750)"));
	CHECK(says(msg, "usermod -aG root"));
}

/* A listening socket at dir/name with mode `mode`; the fd. */
static int listen_at(const char *path, mode_t mode)
{
	int fd = socket(AF_UNIX, SOCK_SEQPACKET, 0);
	struct sockaddr_un a = {.sun_family = AF_UNIX};
	snprintf(a.sun_path, sizeof(a.sun_path), "%s", path);
	if (fd < 0 || bind(fd, (struct sockaddr *)&a, sizeof(a)) != 0 || listen(fd, 4) != 0 || chmod(path, mode) != 0) {
		perror(path);
		return -1;
	}
	return fd;
}

/* mocap_connect(path) as nobody (uid and gid 65534, no other groups) in a
 * child; its error message into msg. */
static bool connect_as_nobody(const char *path, char *msg, size_t cap)
{
	int p[2];
	if (pipe(p) != 0)
		return false;
	pid_t pid = fork();
	if (pid == 0) {
		close(p[0]);
		if (setgroups(0, NULL) != 0 || setgid(65534) != 0 || setuid(65534) != 0)
			_exit(2);
		mocap_client *c = mocap_connect(path, "test_ipc_access");
		if (c)
			_exit(3);
		dprintf(p[1], "%d %s", mocap_errcode(), mocap_errmsg());
		_exit(0);
	}
	close(p[1]);
	ssize_t n = read(p[0], msg, cap - 1);
	msg[n > 0 ? n : 0] = 0;
	close(p[0]);
	int st = 0;
	waitpid(pid, &st, 0);
	CHECK_MSG(WIFEXITED(st) && WEXITSTATUS(st) == 0, "the child as nobody exited with %d (3: it connected)",
		  WIFEXITED(st) ? WEXITSTATUS(st) : -1);
	return n > 0;
}

static void test_real(void)
{
	char dir[] = "/tmp/mocap-access-XXXXXX", sub[64], path[96], inner[128], msg[MCL_ERRMSG_MAX + 16];
	if (!mkdtemp(dir) || chmod(dir, 0755) != 0) {
		CHECK(!"a temporary folder");
		return;
	}
	snprintf(path, sizeof(path), "%s/mocapd.sock", dir);
	int fd = listen_at(path, 0660); /* root's: group root, which nobody is not in */
	CHECK(fd >= 0);
	if (fd >= 0 && connect_as_nobody(path, msg, sizeof(msg))) {
		printf("as nobody, socket 0660: %s\n", msg);
		char want[160];
		snprintf(want, sizeof(want), "%d permission denied connecting to %s: ", MOCAP_E_ACCESS, path);
		CHECK(says(msg, want));
		CHECK(says(msg, "the socket belongs to group root (mode 0660)"));
		CHECK(says(msg, "sudo usermod -aG root $USER, then log in again"));
	}
	/* A folder like /run/mocapd (0750, the daemon's group) hides the socket. */
	snprintf(sub, sizeof(sub), "%s/run", dir);
	snprintf(inner, sizeof(inner), "%s/mocapd.sock", sub);
	int fd2 = mkdir(sub, 0750) == 0 && chmod(sub, 0750) == 0 ? listen_at(inner, 0660) : -1;
	CHECK(fd2 >= 0);
	if (fd2 >= 0 && connect_as_nobody(inner, msg, sizeof(msg))) {
		printf("as nobody, folder 0750: %s\n", msg);
		char want[160];
		snprintf(want, sizeof(want), "its folder %s belongs to group root (mode 0750)", sub);
		CHECK(says(msg, want));
		CHECK(says(msg, "sudo usermod -aG root $USER"));
	}
	if (fd >= 0)
		close(fd);
	if (fd2 >= 0)
		close(fd2);
	unlink(inner);
	rmdir(sub);
	unlink(path);
	rmdir(dir);
}

int main(void)
{
	test_message();
	if (geteuid() != 0)
		printf("not root: the connect as nobody is not run (the made-up stat results are)\n");
	else
		test_real();
	return mc_test_finish("test_ipc_access");
}
