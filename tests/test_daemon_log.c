/* The daemon's log lines stay one line each and carry no control bytes:
 * a client's text (a STEER argument, an actor name) with an ESC byte
 * reached the log and so the operator's terminal, where ESC [ ... starts a
 * terminal control sequence (issue 34, "Also"); newlines were already
 * replaced.  Every byte below 0x20 and DEL become a space. */
#include "log.h"
#include "test_util.h"

#include <fcntl.h>
#include <string.h>
#include <unistd.h>

int main(void)
{
	char path[] = "/tmp/test-daemon-log-XXXXXX";
	int fd = mkstemp(path);
	if (fd < 0)
		TEST_SKIP("cannot create a scratch file");
	int saved = dup(STDERR_FILENO);
	CHECK(saved >= 0 && dup2(fd, STDERR_FILENO) == STDERR_FILENO);
	mcd_log_set_level(MCD_LOG_INFO);
	mcd_info("steer '%s' requested by pid %d (uid %u)", "class \x1b[2J\x1b]0;owned\x07walk\r\nfake: line\x7f\t.", 1, 0u);
	dup2(saved, STDERR_FILENO);
	close(saved);
	char line[4096] = "";
	ssize_t n = pread(fd, line, sizeof(line) - 1, 0);
	close(fd);
	unlink(path);
	CHECK(n > 0);
	printf("logged: %s", line);
	int bad = 0, newlines = 0;
	for (ssize_t i = 0; i < n; i++) {
		unsigned char c = (unsigned char)line[i];
		newlines += c == '\n';
		bad += (c < 0x20 && c != '\n') || c == 0x7f;
	}
	CHECK_MSG(bad == 0, "%d control bytes in the log line", bad);
	CHECK_MSG(newlines == 1 && line[n - 1] == '\n', "%d newlines", newlines);
	CHECK(strstr(line, "steer 'class  [2J ]0;owned walk  fake: line  .' requested by pid 1") != NULL);
	return mc_test_finish("test_daemon_log");
}
