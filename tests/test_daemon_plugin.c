/* mocapd's plugin loader: the trust rule (owner, others-writable,
 * group-writable, symlinks, directories above) and the ABI checks, each
 * refusal with its message. */
#include "log.h"
#include "plugin.h"
#include "test_util.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdbool.h>
#include <string.h>
#include <unistd.h>

static char drivers_dir[PATH_MAX]; /* the build's tests/drivers */
static uid_t uid;
static gid_t gid;

/* The fault driver is built next to this test: <build>/tests/faulty. */
static int find_drivers(void)
{
	char exe[PATH_MAX];
	ssize_t n = readlink("/proc/self/exe", exe, sizeof(exe) - 1);
	if (n <= 0)
		return -1;
	exe[n] = 0;
	*strrchr(exe, '/') = 0;
	snprintf(drivers_dir, sizeof(drivers_dir), "%.4000s/faulty", exe);
	return access(drivers_dir, R_OK) == 0 ? 0 : -1;
}

static int copy_file(const char *from, const char *to, mode_t mode)
{
	int in = open(from, O_RDONLY), out = open(to, O_WRONLY | O_CREAT | O_TRUNC, 0600);
	if (in < 0 || out < 0)
		return -1;
	char buf[65536];
	ssize_t n;
	while ((n = read(in, buf, sizeof(buf))) > 0)
		if (write(out, buf, (size_t)n) != n)
			return -1;
	close(in);
	close(out);
	return chmod(to, mode);
}

static const char *end_after_42(void *ctx, const char *key)
{
	(void)ctx;
	return strcmp(key, "end_after") == 0 ? "42" : NULL;
}

static void expect_refused(const char *dir, const char *name, const char *needle)
{
	mcd_plugin p;
	mc_err err = {{0}};
	int rc = mcd_plugin_load(dir, name, uid, gid, &p, &err);
	CHECK_MSG(rc == -1, "%s/%s was loaded", dir, name);
	if (rc == 0)
		mcd_plugin_unload(&p);
	CHECK_MSG(strstr(err.msg, needle) != NULL, "message '%s' lacks '%s'", err.msg, needle);
}

static void expect_loaded(const char *dir, const char *name)
{
	mcd_plugin p;
	mc_err err = {{0}};
	int rc = mcd_plugin_load(dir, name, uid, gid, &p, &err);
	CHECK_MSG(rc == 0, "%s", err.msg);
	if (rc == 0) {
		CHECK(p.driver && strcmp(p.driver->name, "faulty") == 0);
		CHECK(p.driver->abi_version == MDRV_ABI_VERSION);
		mcd_plugin_unload(&p);
	}
}

/* The rule itself, on synthetic stat results. */
static void test_rule(void)
{
	struct stat st = {0};
	mc_err err;
	const uid_t me = 1000, other = 2000;
	const gid_t mygroup = 100, othergroup = 200;
	st.st_mode = S_IFREG | 0644;
	st.st_uid = 0, st.st_gid = 0;
	CHECK(mcd_path_trusted("f", &st, me, mygroup, false, &err) == 0);
	st.st_uid = me;
	CHECK(mcd_path_trusted("f", &st, me, mygroup, false, &err) == 0);
	st.st_uid = other;
	CHECK(mcd_path_trusted("f", &st, me, mygroup, false, &err) == -1);
	CHECK(strstr(err.msg, "owned by uid 2000, which is neither root nor the daemon's user (uid 1000)"));
	st.st_uid = 0;
	st.st_mode = S_IFREG | 0646;
	CHECK(mcd_path_trusted("f", &st, me, mygroup, false, &err) == -1);
	CHECK(strstr(err.msg, "writable by others (mode 0646)"));
	/* group-writable: fine for root's group and the daemon's group only */
	st.st_mode = S_IFREG | 0664;
	st.st_gid = 0;
	CHECK(mcd_path_trusted("f", &st, me, mygroup, false, &err) == 0);
	st.st_gid = mygroup;
	CHECK(mcd_path_trusted("f", &st, me, mygroup, false, &err) == 0);
	st.st_gid = othergroup;
	CHECK(mcd_path_trusted("f", &st, me, mygroup, false, &err) == -1);
	CHECK(strstr(err.msg, "writable by group gid 200"));
	/* not group-writable: any group may own it */
	st.st_mode = S_IFREG | 0644;
	CHECK(mcd_path_trusted("f", &st, me, mygroup, false, &err) == 0);
	/* sticky world-writable directories are allowed above the plugin
	 * directory only, never as the plugin directory itself */
	st.st_mode = S_IFDIR | 01777;
	st.st_gid = 0;
	CHECK(mcd_path_trusted("/tmp", &st, me, mygroup, true, &err) == 0);
	CHECK(mcd_path_trusted("/tmp", &st, me, mygroup, false, &err) == -1);
	st.st_mode = S_IFDIR | 0777;
	CHECK(mcd_path_trusted("/x", &st, me, mygroup, true, &err) == -1);
}

/* The frame count the host reads from an opened faulty camera with
 * end_after = 42 (0: not known). */
static uint64_t faulty_frame_count(const mdrv_driver *drv)
{
	mdrv_host host = {.config_get = end_after_42};
	char err[256];
	void *dev = drv->open(&host, err, sizeof err);
	CHECK_MSG(dev != NULL, "open: %s", err);
	uint64_t n = dev ? mcd_driver_frame_count(drv, dev) : 0;
	if (dev)
		drv->close(dev);
	return n;
}

/* An ABI 3 plugin (built before frame_count was appended) loads; its
 * descriptor has no frame_count, so the host does not read one, even
 * where (as in this build of faulty) the memory after `modes` holds one. */
static void test_old_abi(const char *bad)
{
	mcd_plugin p;
	mc_err err = {{0}};
	CHECK_MSG(mcd_plugin_load(bad, "oldabi", uid, gid, &p, &err) == 0, "an ABI 3 plugin refused: %s", err.msg);
	if (!p.driver)
		return;
	CHECK(p.driver->abi_version == 3 && p.driver->frame_count != NULL);
	CHECK(faulty_frame_count(p.driver) == 0);
	mcd_plugin_unload(&p);
	CHECK(mcd_plugin_load(drivers_dir, "faulty", uid, gid, &p, &err) == 0);
	if (p.driver)
		CHECK(faulty_frame_count(p.driver) == 42);
	mcd_plugin_unload(&p);
}

static void test_build_dir(void)
{
	expect_loaded(drivers_dir, "faulty");
	char bad[PATH_MAX + 8];
	snprintf(bad, sizeof(bad), "%s/bad", drivers_dir);
	expect_refused(bad, "badabi", "built for driver ABI version 999, but this mocapd speaks versions 3 to 4");
	test_old_abi(bad);
	expect_refused(bad, "noentry", "exports no mdrv_entry(); not a mocapd driver plugin");
	expect_refused(drivers_dir, "nosuch", "no mocap-driver-nosuch.so in");
	expect_refused(drivers_dir, "nosuch", "(drivers there: faulty)");
	expect_refused(drivers_dir, "../drivers/faulty", "not a valid driver name");
	expect_refused("/nonexistent/plugins", "faulty", "plugin directory /nonexistent/plugins: No such file");
}

/* Real files in a scratch directory under /tmp (sticky, so allowed above). */
static void test_scratch(void)
{
	char top[] = "/tmp/mocapd-plugin-XXXXXX";
	if (!mkdtemp(top)) {
		CHECK(!"mkdtemp");
		return;
	}
	chmod(top, 0755);
	char dir[256], so[PATH_MAX], src[PATH_MAX + 64], link[PATH_MAX];
	snprintf(dir, sizeof(dir), "%s/plugins", top);
	snprintf(so, sizeof(so), "%s/mocap-driver-faulty.so", dir);
	snprintf(src, sizeof(src), "%s/mocap-driver-faulty.so", drivers_dir);
	CHECK(mkdir(dir, 0755) == 0);
	CHECK(copy_file(src, so, 0755) == 0);
	expect_loaded(dir, "faulty");

	/* writable by others: the file, then the directory */
	chmod(so, 0757);
	expect_refused(dir, "faulty", "mocap-driver-faulty.so: file writable by others (mode 0757); refused");
	chmod(so, 0755);
	chmod(dir, 0777);
	expect_refused(dir, "faulty", "plugins: directory writable by others (mode 0777); refused");
	chmod(dir, 01777); /* sticky does not excuse the plugin directory itself */
	expect_refused(dir, "faulty", "directory writable by others");
	chmod(dir, 0755);
	/* a directory above, writable by others without the sticky bit */
	chmod(top, 0777);
	expect_refused(dir, "faulty", "directory writable by others (mode 0777); refused");
	chmod(top, 0755);
	expect_loaded(dir, "faulty");

	/* group-writable: refused for a foreign group, fine for ours */
	chmod(so, 0775);
	bool root = geteuid() == 0;
	gid_t foreign = gid + 4242;
	if (root)
		CHECK(chown(so, 0, foreign) == 0);
	/* Not root: our files carry our group; pretend the daemon's group is
	 * another one. */
	gid_t daemon_gid = root ? gid : gid + 1;
	mcd_plugin p;
	mc_err err = {{0}};
	int rc = mcd_plugin_load(dir, "faulty", uid, daemon_gid, &p, &err);
	CHECK_MSG(rc == -1 && strstr(err.msg, "file writable by group gid"), "%s", err.msg);
	if (rc == 0)
		mcd_plugin_unload(&p);
	if (root) {
		CHECK(chown(so, 0, gid) == 0);
		expect_loaded(dir, "faulty");
	}
	chmod(so, 0755);

	/* owned by a user who is neither root nor the daemon */
	if (root) {
		CHECK(chown(so, 4242, 0) == 0);
		expect_refused(dir, "faulty", "file owned by uid 4242, which is neither root nor the daemon's user");
		CHECK(chown(so, 0, 0) == 0);
		CHECK(chown(dir, 4242, 0) == 0);
		expect_refused(dir, "faulty", "directory owned by uid 4242");
		CHECK(chown(dir, 0, 0) == 0);
	} else {
		rc = mcd_plugin_load(dir, "faulty", uid + 1, gid, &p, &err);
		CHECK_MSG(rc == -1 && strstr(err.msg, "which is neither root nor the daemon's user"), "%s", err.msg);
		if (rc == 0)
			mcd_plugin_unload(&p);
	}

	/* a symbolic link in place of the plugin */
	char real[PATH_MAX + 16];
	snprintf(real, sizeof(real), "%s/real.so", dir);
	CHECK(rename(so, real) == 0);
	CHECK(symlink(real, so) == 0);
	expect_refused(dir, "faulty", "is a symbolic link; plugins must be regular files; refused");
	unlink(so);
	/* a directory with the plugin's name */
	CHECK(mkdir(so, 0755) == 0);
	expect_refused(dir, "faulty", "not a regular file");
	rmdir(so);
	/* not a shared object at all */
	int fd = open(so, O_WRONLY | O_CREAT, 0755);
	CHECK(fd >= 0 && write(fd, "hello", 5) == 5);
	close(fd);
	expect_refused(dir, "faulty", "cannot load:");
	unlink(so);

	/* a plugin directory reached through a link is checked where it leads */
	snprintf(link, sizeof(link), "%s/via-link", top);
	CHECK(symlink(dir, link) == 0);
	CHECK(rename(real, so) == 0);
	expect_loaded(link, "faulty");
	chmod(dir, 0777);
	expect_refused(link, "faulty", "directory writable by others");
	chmod(dir, 0755);
	unlink(link);
	unlink(so);
	rmdir(dir);
	rmdir(top);
}

int main(void)
{
	mcd_log_set_level(MCD_LOG_ERROR);
	uid = geteuid();
	gid = getegid();
	test_rule();
	if (find_drivers() != 0)
		TEST_SKIP("the fault driver is not built next to this test (%s)", drivers_dir);
	test_build_dir();
	test_scratch();
	return mc_test_finish("test_daemon_plugin");
}
