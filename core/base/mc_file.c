#include "base/mc_file.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <fcntl.h>
#include <libgen.h>
#include <sys/stat.h>
#include <unistd.h>

static const char *file_kind(mode_t m)
{
	if (S_ISDIR(m))
		return "a directory";
	if (S_ISCHR(m))
		return "a character device";
	if (S_ISBLK(m))
		return "a block device";
	if (S_ISFIFO(m))
		return "a FIFO";
	if (S_ISSOCK(m))
		return "a socket";
	return "not a plain file";
}

FILE *mc_file_open_regular(const char *path, mc_err *err)
{
	/* O_NONBLOCK: opening a FIFO for reading otherwise waits for a writer,
	 * for ever (issue 34: a FIFO named cam-left.mcr stalled mocap-export
	 * and mocapd --check).  A regular file ignores the flag. */
	int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
	if (fd < 0) {
		mc_err_set(err, "%s: cannot open: %s", path, strerror(errno));
		return NULL;
	}
	struct stat st;
	if (fstat(fd, &st) != 0) {
		mc_err_set(err, "%s: %s", path, strerror(errno));
		close(fd);
		return NULL;
	}
	if (!S_ISREG(st.st_mode)) {
		mc_err_set(err, "%s: not a regular file (%s)", path, file_kind(st.st_mode));
		close(fd);
		return NULL;
	}
	fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) & ~O_NONBLOCK);
	FILE *f = fdopen(fd, "rb");
	if (!f) {
		mc_err_set(err, "%s: %s", path, strerror(errno));
		close(fd);
	}
	return f;
}

int mc_file_refuse_special(const char *path, mc_err *err)
{
	struct stat st; /* stat, not open: it does not wait on a FIFO */
	if (stat(path, &st) != 0 || S_ISREG(st.st_mode))
		return 0;
	return mc_err_set(err, "%s: not a regular file (%s)", path, file_kind(st.st_mode));
}

int mc_file_read(const char *path, size_t max_bytes, uint8_t **data, size_t *bytes, mc_err *err)
{
	*data = NULL;
	*bytes = 0;
	FILE *f = mc_file_open_regular(path, err);
	if (!f)
		return -1;
	struct stat st;
	if (fstat(fileno(f), &st) != 0) {
		int e = errno;
		fclose(f);
		return mc_err_set(err, "%s: %s", path, strerror(e));
	}
	if ((unsigned long long)st.st_size > max_bytes) {
		fclose(f);
		return mc_err_set(err, "%s: %lld bytes, more than the %zu accepted", path, (long long)st.st_size,
				  max_bytes);
	}
	size_t n = (size_t)st.st_size;
	uint8_t *buf = malloc(n + 1);
	if (!buf) {
		fclose(f);
		return mc_err_set(err, "%s: out of memory (%zu bytes)", path, n);
	}
	size_t got = fread(buf, 1, n, f);
	int failed = ferror(f);
	fclose(f);
	if (failed || got != n) {
		free(buf);
		return mc_err_set(err, "%s: read error (%zu of %zu bytes)", path, got, n);
	}
	buf[n] = 0;
	*data = buf;
	*bytes = n;
	return 0;
}

/* Writes all of data to fd; 0, or the errno. */
static int write_all(int fd, const void *data, size_t n)
{
	size_t done = 0;
	while (done < n) {
		ssize_t w = write(fd, (const char *)data + done, n - done);
		if (w < 0 && errno == EINTR)
			continue;
		if (w <= 0)
			return w < 0 ? errno : ENOSPC;
		done += (size_t)w;
	}
	return 0;
}

int mc_file_write_atomic(const char *path, const void *data, size_t n, mc_err *err)
{
	char tmp[4096], dir[4096];
	if ((size_t)snprintf(tmp, sizeof(tmp), "%s.tmp.%ld", path, (long)getpid()) >= sizeof(tmp))
		return mc_err_set(err, "%s: path too long", path);
	int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0640);
	int e = fd < 0 ? errno : write_all(fd, data, n);
	if (!e && fsync(fd) < 0)
		e = errno;
	if (fd >= 0 && close(fd) < 0 && !e)
		e = errno;
	if (e) {
		unlink(tmp);
		return mc_err_set(err, "%s: cannot write: %s", path, strerror(e));
	}
	if (rename(tmp, path) != 0) {
		e = errno;
		unlink(tmp);
		return mc_err_set(err, "%s: cannot rename %s into place: %s", path, tmp, strerror(e));
	}
	/* the rename itself, durable */
	snprintf(dir, sizeof(dir), "%s", path);
	int dfd = open(dirname(dir), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
	if (dfd >= 0) {
		fsync(dfd);
		close(dfd);
	}
	return 0;
}

FILE *mc_file_create_or_exit(const char *prog, const char *path)
{
	FILE *f = fopen(path, "w");
	if (!f)
		mc_fail_exit(prog, 1, "%s: %s", path, strerror(errno));
	return f;
}

void mc_file_close_or_exit(const char *prog, FILE *f, const char *path)
{
	if (ferror(f) | (fclose(f) != 0))
		mc_fail_exit(prog, 1, "%s: write error", path);
}
