/* mocapd's output filter end to end ([output] filter, docs/CONFIG.md): the
 * bundled clip (tests/data/ego_demo) tracked twice, with the filter off
 * and with the One-Euro filter on; the printed skeletons (what clients
 * get) are compared.  With the filter on, the first skeleton is the
 * tracker's own, the joints' frame-to-frame acceleration (jitter) is
 * lower by a stated factor, and the poses stay near the raw ones (the
 * filter follows rather than freezes).  The latest-pose block, read
 * during the filtered run, holds the printed (filtered) skeletons.  Then a
 * reload turns the filter on in a running daemon. */
#include "daemon/harness.h"
#include "body/mc_model.h"
#include "mocap.h"
#include "test_util.h"

#define MAX_LINES 128

/* 10 fps, so that the tracker (on two shared cores) takes every frame set
 * and both runs track the same ones; the clip then plays at a third of its
 * speed.  No loop: --exit-at-end ends the run. */
#define CONF(output_section)                                                            \
	"[daemon]\nplugin_dir = @DRIVERS@\n"                                            \
	"[camera left]\ndriver = files\nrig_camera = left\nrate = 10\n"                 \
	"path = @REPO@/tests/data/ego_demo/left\n"                                      \
	"[camera right]\ndriver = files\nrig_camera = right\nrate = 10\n"               \
	"path = @REPO@/tests/data/ego_demo/right\n"                                     \
	"[tracker]\nrig = @REPO@/config/rigs/ego_stereo.json\n"                         \
	"model = @REPO@/config/models/default.json\n"                                   \
	"init_joints = @REPO@/tests/data/ego_demo/gt.json\n"                            \
	"[socket]\npath = @SOCK@\n" output_section

#define FRAME_S 0.1 /* the frame sets' spacing at rate 10 */

#define ONE_EURO "[output]\nfilter = one_euro\nfilter_max_gap_ms = 1000\n"

typedef struct {
	unsigned long long seq;
	double t;
	bool ok;
	int njoints;
	mc_vec3 joint[MC_MAX_JOINTS];
} printed_pose;

static char repo[PATH_MAX];

/* mcd_run_config with @DRIVERS@ and @REPO@ filled in too. */
static void write_config(mcd_run *r, const char *tmpl)
{
	char text[8192] = "";
	for (const char *p = tmpl; *p;) {
		if (strncmp(p, "@DRIVERS@", 9) == 0) {
			strcat(text, mcd_build_dir);
			strcat(text, "/drivers");
			p += 9;
		} else if (strncmp(p, "@REPO@", 6) == 0) {
			strcat(text, repo);
			p += 6;
		} else
			strncat(text, p++, 1);
	}
	mcd_run_config(r, text);
}

/* One --print line: "frame N t=T STATE ...ms cams a/b name=(x,y,z) ...". */
static bool parse_line(const char *line, printed_pose *p)
{
	char state[32];
	if (sscanf(line, "frame %llu t=%lf %31s", &p->seq, &p->t, state) != 3 || strstr(line, "(not tracked)"))
		return false;
	p->ok = strcmp(state, "ok") == 0 || strcmp(state, "uncertain") == 0;
	p->njoints = 0;
	const char *end = strchr(line, '\n');
	for (const char *at = strstr(line, "=("); at && (!end || at < end) && p->njoints < MC_MAX_JOINTS;
	     at = strstr(at + 2, "=(")) {
		mc_vec3 *v = &p->joint[p->njoints];
		if (sscanf(at + 2, "%lf,%lf,%lf", &v->x, &v->y, &v->z) == 3)
			p->njoints++;
	}
	return p->njoints > 0;
}

static int parse_output(const char *out, printed_pose *poses, int cap)
{
	int n = 0;
	for (const char *line = out; line && *line && n < cap;) {
		if (parse_line(line, &poses[n]))
			n++;
		const char *nl = strchr(line, '\n');
		line = nl ? nl + 1 : NULL;
	}
	return n;
}

/* Reads the poses the daemon writes into the latest-pose block (those
 * that are newest when the reader looks) until the daemon exits. */
static int read_block(mcd_run *r, mocap_skeleton_frame *frames, int cap)
{
	if (!mcd_run_wait_notify(r, "READY=1", 60000))
		return 0;
	mocap_client *c = mocap_connect(r->sock, "filter-test");
	mocap_pose_block *b = c ? mocap_pose_block_map(c) : NULL;
	CHECK_MSG(c && b, "%s", mocap_errmsg());
	int n = 0;
	uint64_t seen = 0;
	uint64_t end = mcd_now_ms() + 120000;
	while (b && n < cap && mcd_now_ms() < end) {
		if (mocap_pose_block_wait(b, seen, &frames[n], 500) == 1)
			seen = frames[n++].seq;
		else if (!mcd_run_alive(r))
			break;
	}
	mocap_pose_block_unmap(b);
	mocap_close(c);
	return n;
}

/* Runs the clip with `output_section`; returns the tracked poses printed
 * (skips the test without OpenCL); with `block`, also the poses of the
 * latest-pose block (*nblock of them). */
static int run_clip(const char *conf, printed_pose *poses, int cap, mocap_skeleton_frame *block, int *nblock)
{
	mcd_run r;
	CHECK(mcd_run_init(&r));
	write_config(&r, conf);
	const char *const args[] = {"--print", "--exit-at-end", NULL};
	CHECK(mcd_run_start(&r, args, NULL));
	if (block)
		*nblock = read_block(&r, block, cap);
	int rc = mcd_run_wait_exit(&r, 180000);
	char *log = rc == 1 ? mcd_read_file(r.log) : NULL;
	bool no_cl = log && (strstr(log, "OpenCL") || strstr(log, "CL_")) && strstr(log, "error");
	free(log);
	if (no_cl) {
		mcd_run_cleanup(&r);
		TEST_SKIP("the tracker cannot run here (no usable OpenCL device)");
	}
	CHECK_MSG(rc == 0, "exit %d", rc);
	char *out = mcd_read_file(r.out);
	int n = out ? parse_output(out, poses, cap) : 0;
	free(out);
	if (mc_test_failures)
		mcd_run_dump(&r, "filter");
	mcd_run_cleanup(&r);
	return n;
}

/* Whether b is the frame set after a (none skipped between them). */
static bool next_set(const printed_pose *a, const printed_pose *b)
{
	return b->t > a->t && b->t - a->t < 1.5 * FRAME_S && a->njoints == b->njoints;
}

/* Mean joint acceleration (m/s^2) over runs of three consecutive frame
 * sets that were all tracked well: the jitter a client sees. */
static double mean_acceleration(const printed_pose *p, int n, int *triples)
{
	double sum = 0;
	int count = 0;
	for (int i = 1; i + 1 < n; i++) {
		const printed_pose *a = &p[i - 1], *b = &p[i], *c = &p[i + 1];
		if (!a->ok || !b->ok || !c->ok || !next_set(a, b) || !next_set(b, c))
			continue;
		double dt1 = b->t - a->t, dt2 = c->t - b->t;
		for (int j = 0; j < b->njoints; j++) {
			mc_vec3 v1 = mc_v3_scale(mc_v3_sub(b->joint[j], a->joint[j]), 1 / dt1);
			mc_vec3 v2 = mc_v3_scale(mc_v3_sub(c->joint[j], b->joint[j]), 1 / dt2);
			sum += mc_v3_norm(mc_v3_sub(v2, v1)) / (0.5 * (dt1 + dt2));
		}
		count++;
	}
	*triples = count;
	return count ? sum / (count * p[0].njoints) : 0;
}

/* Mean distance (m) between the joints of the two runs at the same frame
 * set (the same time since the first: the files driver stamps frame k at
 * epoch + k / rate, and the tracking thread may skip a set in one run). */
static double mean_offset(const printed_pose *a, int na, const printed_pose *b, int nb)
{
	double sum = 0;
	int count = 0;
	for (int i = 0; i < na; i++)
		for (int k = 0; k < nb; k++) {
			if (fabs(a[i].t - b[k].t) > 0.001 || a[i].njoints != b[k].njoints)
				continue;
			for (int j = 0; j < a[i].njoints; j++)
				sum += mc_v3_norm(mc_v3_sub(a[i].joint[j], b[k].joint[j]));
			count += a[i].njoints;
		}
	return count ? sum / count : 1e9;
}

/* How many block poses are one of the printed ones (every joint within
 * the print's rounding). */
static int block_in_print(const mocap_skeleton_frame *block, int nblock, const printed_pose *p, int n)
{
	int found = 0;
	for (int i = 0; i < nblock; i++) {
		bool match = false;
		for (int k = 0; k < n && !match; k++) {
			match = block[i].njoints == p[k].njoints;
			for (int j = 0; j < p[k].njoints && match; j++) {
				const double *b = block[i].joints[j].position;
				match = fabs(b[0] - p[k].joint[j].x) < 6e-4 && fabs(b[1] - p[k].joint[j].y) < 6e-4 &&
					fabs(b[2] - p[k].joint[j].z) < 6e-4;
			}
		}
		found += match;
	}
	return found;
}

static void test_smoother(void)
{
	printed_pose *off = calloc(MAX_LINES, sizeof(*off)), *on = calloc(MAX_LINES, sizeof(*on));
	mocap_skeleton_frame *block = calloc(MAX_LINES, sizeof(*block));
	CHECK(off && on && block);
	if (!off || !on || !block)
		goto out;
	int noff = run_clip(CONF(""), off, MAX_LINES, NULL, NULL), nblock = 0;
	int non = run_clip(CONF(ONE_EURO), on, MAX_LINES, block, &nblock);
	int in_print = block_in_print(block, nblock, on, non);
	printf("latest-pose block: %d poses read, %d of them as printed\n", nblock, in_print);
	CHECK_MSG(nblock >= 10 && in_print == nblock, "%d of %d block poses printed", in_print, nblock);
	CHECK_MSG(noff >= 30 && non >= 30, "tracked %d without the filter, %d with it", noff, non);
	if (noff < 30 || non < 30)
		goto out;
	/* The first skeleton passes through: the same as the tracker's. */
	CHECK_MSG(off[0].t == on[0].t && mean_offset(off, 1, on, 1) < 0.002, "first poses %.4f m apart",
		  mean_offset(off, 1, on, 1));
	int toff, ton;
	double acc_off = mean_acceleration(off, noff, &toff), acc_on = mean_acceleration(on, non, &ton);
	double offset = mean_offset(off, noff, on, non);
	printf("filter: %d and %d frame sets tracked; mean joint acceleration %.2f m/s^2 raw, %.2f filtered (%.2fx); "
	       "filtered joints %.1f mm from the raw on average\n",
	       noff, non, acc_off, acc_on, acc_off / acc_on, offset * 1e3);
	CHECK_MSG(toff >= 20 && ton >= 20, "%d and %d runs of three frame sets", toff, ton);
	CHECK_MSG(acc_on <= 0.7 * acc_off, "filtered %.2f against raw %.2f m/s^2", acc_on, acc_off);
	CHECK_MSG(offset < 0.03, "filtered joints %.1f mm from the raw", offset * 1e3);
out:
	free(off);
	free(on);
	free(block);
}

/* A reload turns the filter on in a running daemon. */
static void test_reload(void)
{
	mcd_run r;
	CHECK(mcd_run_init(&r));
	write_config(&r, CONF(""));
	const char *const args[] = {NULL};
	CHECK(mcd_run_start(&r, args, NULL));
	CHECK(mcd_run_wait_notify(&r, "READY=1", 60000));
	CHECK(!mcd_run_wait_log(&r, "output:", 0)); /* off: nothing said */
	write_config(&r, CONF(ONE_EURO "filter_beta = 2\n"));
	mcd_run_signal(&r, SIGHUP);
	CHECK(mcd_run_wait_log(&r, "output: One-Euro filter on (min cutoff 1 Hz, beta 2 per m/s, speed cutoff 1 Hz; "
				   "53 ms lag at 1 m/s; a gap over 1000 ms restarts it)", 10000));
	mcd_run_stop(&r, 30000, "reload");
}

int main(void)
{
	mcd_require_files_driver(repo, sizeof(repo));
	test_reload();
	test_smoother();
	return mc_test_finish("test_daemon_filter");
}
