/* Minimal test harness shared by the test programs.
 *
 * A test program exits 0 when every check passed, 1 when one failed and 77
 * when it cannot run here (after printing "SKIP: reason").  Data from
 * ../shared/data is found through mc_test_data_dir(). */
#ifndef MC_TEST_UTIL_H
#define MC_TEST_UTIL_H

#include <math.h>
#include <stdbool.h>
#include <unistd.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>

static int mc_test_failures;

#define CHECK(cond)                                                                   \
	do {                                                                          \
		if (!(cond)) {                                                        \
			fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond); \
			mc_test_failures++;                                           \
		}                                                                     \
	} while (0)

#define CHECK_MSG(cond, ...)                                                          \
	do {                                                                          \
		if (!(cond)) {                                                        \
			fprintf(stderr, "%s:%d: CHECK failed: %s: ", __FILE__, __LINE__, #cond); \
			fprintf(stderr, __VA_ARGS__);                                 \
			fputc('\n', stderr);                                          \
			mc_test_failures++;                                           \
		}                                                                     \
	} while (0)

#define CHECK_NEAR(a, b, tol)                                                         \
	do {                                                                          \
		double a_ = (a), b_ = (b);                                            \
		if (!(fabs(a_ - b_) <= (tol))) {                                      \
			fprintf(stderr, "%s:%d: CHECK_NEAR failed: %s = %.10g, %s = %.10g, tol %g\n", \
				__FILE__, __LINE__, #a, a_, #b, b_, (double)(tol));   \
			mc_test_failures++;                                           \
		}                                                                     \
	} while (0)

#define TEST_SKIP(...)                                                                \
	do {                                                                          \
		printf("SKIP: ");                                                     \
		printf(__VA_ARGS__);                                                  \
		printf("\n");                                                         \
		exit(77);                                                             \
	} while (0)

/* The live head-mounted detector, relative to the repository root
 * (config/models also ships the slower ego_offline_detector.onnx). */
#define MC_TEST_LIVE_EGO_MODEL "config/models/ego_detector.onnx"

/* The folder `up` levels above this test program (/proc/self/exe), e.g.
 * the build folder for up = 2 from <build>/tests/TEST; false if there is
 * none. */
static inline bool mc_test_build_dir(int up, char *out, size_t cap)
{
	char exe[4096];
	ssize_t n = readlink("/proc/self/exe", exe, sizeof(exe) - 1);
	if (n <= 0)
		return false;
	exe[n] = 0;
	for (int i = 0; i < up; i++) {
		char *slash = strrchr(exe, '/');
		if (!slash)
			return false;
		*slash = 0;
	}
	snprintf(out, cap, "%s", exe);
	return true;
}

/* The path of tool `name` built next to this test (BUILD/bin/NAME, the test
 * being BUILD/tests/TEST), into out; skips the test when it is not built. */
static inline void mc_test_find_tool(const char *argv0, const char *name, char *out, size_t cap)
{
	const char *slash = strrchr(argv0, '/');
	int dir = slash ? (int)(slash - argv0) : 1;
	snprintf(out, cap, "%.*s/../bin/%s", dir, slash ? argv0 : ".", name);
	if (access(out, X_OK) != 0)
		TEST_SKIP("%s is not built (make builds the tools before the tests)", out);
}

static inline int mc_test_finish(const char *name)
{
	if (mc_test_failures) {
		fprintf(stderr, "%s: %d check(s) failed\n", name, mc_test_failures);
		return 1;
	}
	printf("%s: ok\n", name);
	return 0;
}

/* ../shared/data, or $MOCAP_DATA_DIR. NULL (with a message) if missing. */
static inline const char *mc_test_data_dir(void)
{
	const char *d = getenv("MOCAP_DATA_DIR");
	if (!d)
		d = "../shared/data";
	struct stat st;
	if (stat(d, &st) != 0 || !S_ISDIR(st.st_mode)) {
		printf("evaluation data not found at %s (set MOCAP_DATA_DIR)\n", d);
		return NULL;
	}
	return d;
}

/* Deterministic uniform random numbers in [0, 1) for tests. */
static inline double mc_test_rand(unsigned long long *state)
{
	*state = *state * 6364136223846793005ULL + 1442695040888963407ULL;
	return (double)(*state >> 11) * (1.0 / 9007199254740992.0);
}

/* Runs a shell command and captures its output (as much as fits in out,
 * NUL-terminated; the rest is read and dropped, so that the command does
 * not die of SIGPIPE).  Returns its exit status, or -1 when it could not
 * run or did not exit normally. */
static inline int mc_test_run(const char *cmd, char *out, size_t cap)
{
	FILE *p = popen(cmd, "r");
	if (!p)
		return -1;
	size_t n = fread(out, 1, cap - 1, p);
	out[n] = 0;
	char drain[4096];
	while (fread(drain, 1, sizeof(drain), p) > 0)
		;
	int st = pclose(p);
	return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

#endif
