/* mocap-vmc end to end: a liblo OSC server in this test receives the VMC
 * stream that mocap-vmc sends for (1) mocap-testpub's pelvis-rooted
 * skeleton in an outside-in (z-up) world and (2) mocapd tracking the
 * bundled clip with the default head-rooted model in the head rig's own
 * frame.  The bones decoded from each bundle, put through Unity forward
 * kinematics written here, land on the joints of one published frame within
 * 1 mm.  Also: bundles are whole (root, bones, OK, T), the avatar stands
 * upright, and bad options, bone files and a missing daemon get clear
 * errors and the documented exit codes. */
#include "base/mc_math.h"
#include "daemon/harness.h"
#include "mocap.h"
#include "test_util.h"

#include "lo_args.h"
#include <pthread.h>

static char vmc_bin[PATH_MAX + 32], testpub_bin[PATH_MAX + 32], repo[PATH_MAX];

/* The bones and joints this test expects, with Unity's parents (its own
 * table: not the one mocap-vmc uses). */
static const struct {
	const char *bone, *joint, *parent;
} expect[] = {
	{"Hips", "pelvis", NULL},
	{"Spine", "spine", "Hips"},
	{"Neck", "neck", "Spine"},
	{"Head", "head", "Neck"},
	{"LeftUpperArm", "left_shoulder", "Spine"},
	{"LeftLowerArm", "left_elbow", "LeftUpperArm"},
	{"LeftHand", "left_wrist", "LeftLowerArm"},
	{"RightUpperArm", "right_shoulder", "Spine"},
	{"RightLowerArm", "right_elbow", "RightUpperArm"},
	{"RightHand", "right_wrist", "RightLowerArm"},
	{"LeftUpperLeg", "left_hip", "Hips"},
	{"LeftLowerLeg", "left_knee", "LeftUpperLeg"},
	{"LeftFoot", "left_ankle", "LeftLowerLeg"},
	{"LeftToes", "left_toe", "LeftFoot"},
	{"RightUpperLeg", "right_hip", "Hips"},
	{"RightLowerLeg", "right_knee", "RightUpperLeg"},
	{"RightFoot", "right_ankle", "RightLowerLeg"},
	{"RightToes", "right_toe", "RightFoot"},
};
#define NEXPECT ((int)(sizeof(expect) / sizeof(expect[0])))

/* ---- the OSC receiver ---- */

typedef struct {
	bool have[NEXPECT];
	mc_vec3 pos[NEXPECT];
	mc_quat rot[NEXPECT]; /* Unity local, (w, x, y, z) */
	int roots, oks, times, unknown;
	int tracking;
} bundle;

#define MAX_BUNDLES 256
static struct {
	pthread_mutex_t lock;
	bundle b[MAX_BUNDLES];
	int n, open;
} rx = {.lock = PTHREAD_MUTEX_INITIALIZER};

static bundle *current(void) { return rx.n < MAX_BUNDLES ? &rx.b[rx.n] : NULL; }

static int on_bundle_start(lo_timetag t, void *user)
{
	(void)t, (void)user;
	pthread_mutex_lock(&rx.lock);
	if (rx.n < MAX_BUNDLES)
		memset(&rx.b[rx.n], 0, sizeof(bundle));
	rx.open = 1;
	pthread_mutex_unlock(&rx.lock);
	return 0;
}

static int on_bundle_end(void *user)
{
	(void)user;
	pthread_mutex_lock(&rx.lock);
	if (rx.open && rx.n < MAX_BUNDLES)
		rx.n++;
	rx.open = 0;
	pthread_mutex_unlock(&rx.lock);
	return 0;
}

static int on_message(const char *path, const char *types, lo_arg **argv, int argc, lo_message m, void *user)
{
	(void)m, (void)user;
	pthread_mutex_lock(&rx.lock);
	bundle *b = rx.open ? current() : NULL;
	if (b && strcmp(path, "/VMC/Ext/Bone/Pos") == 0 && strcmp(types, "sfffffff") == 0) {
		int k = -1;
		for (int i = 0; i < NEXPECT; i++)
			k = strcmp((const char *)argv[0], expect[i].bone) == 0 ? i : k;
		if (k < 0)
			b->unknown++;
		else {
			b->have[k] = true;
			b->pos[k] = mc_v3(lo_arg_float(argv[1]), lo_arg_float(argv[2]), lo_arg_float(argv[3]));
			b->rot[k] = (mc_quat){lo_arg_float(argv[7]), lo_arg_float(argv[4]), lo_arg_float(argv[5]), lo_arg_float(argv[6])};
		}
	} else if (b && strcmp(path, "/VMC/Ext/Root/Pos") == 0 && strcmp(types, "sfffffff") == 0 &&
		   strcmp((const char *)argv[0], "root") == 0 && lo_arg_float(argv[7]) == 1.0f)
		b->roots++;
	else if (b && strcmp(path, "/VMC/Ext/OK") == 0 && argc == 4 && strcmp(types, "iiii") == 0) {
		b->oks++;
		b->tracking = lo_arg_int(argv[3]);
	} else if (b && strcmp(path, "/VMC/Ext/T") == 0 && strcmp(types, "f") == 0)
		b->times++;
	else if (b)
		b->unknown++;
	pthread_mutex_unlock(&rx.lock);
	return 0;
}

/* ---- the published frames ---- */

#define MAX_FRAMES 2048
static mocap_skeleton_frame frames[MAX_FRAMES];
static int nframes;
static mocap_skeleton_def sk;

static int joint_index(const char *name)
{
	for (int j = 0; j < sk.njoints; j++)
		if (strcmp(sk.joints[j].name, name) == 0)
			return j;
	return -1;
}

/* Unity forward kinematics of a bundle: world positions of its bones. */
static void unity_fk(const bundle *b, mc_vec3 *world_pos)
{
	mc_quat world[NEXPECT];
	for (int i = 0; i < NEXPECT; i++) {
		if (!b->have[i])
			continue;
		int p = -1;
		for (int k = 0; k < i && expect[i].parent; k++)
			p = strcmp(expect[k].bone, expect[i].parent) == 0 ? k : p;
		world[i] = p < 0 ? mc_quat_normalize(b->rot[i]) : mc_quat_mul(world[p], mc_quat_normalize(b->rot[i]));
		world_pos[i] = p < 0 ? b->pos[i] : mc_v3_add(world_pos[p], mc_quat_rotate(world[p], b->pos[i]));
	}
}

static mc_vec3 joint_pos(const mocap_skeleton_frame *f, int j)
{
	return mc_v3(f->joints[j].position[0], f->joints[j].position[1], f->joints[j].position[2]);
}

/* The largest miss of a bundle against a frame; world: z-up world seen as
 * Unity (x, z, y), else a rigid fit after mirroring (the head-up frame
 * depends on the head's pose; the test does not redo it). */
static double miss(const bundle *b, const mocap_skeleton_frame *f, bool zup_world, int *nbones)
{
	mc_vec3 u[NEXPECT], from[NEXPECT], to[NEXPECT];
	double w[NEXPECT];
	int n = 0;
	unity_fk(b, u);
	for (int i = 0; i < NEXPECT; i++) {
		int j = joint_index(expect[i].joint);
		if (!b->have[i] || j < 0)
			continue;
		mc_vec3 p = joint_pos(f, j);
		from[n] = zup_world ? mc_v3(p.x, p.z, p.y) : p;
		to[n] = zup_world ? u[i] : mc_v3(-u[i].x, u[i].y, u[i].z);
		w[n++] = 1;
	}
	*nbones = n;
	mc_xform x = mc_xform_identity();
	if (!zup_world)
		x = mc_xform_fit_rigid(from, to, w, n);
	double worst = 0;
	for (int i = 0; i < n; i++) {
		double e = mc_v3_norm(mc_v3_sub(mc_xform_apply(x, from[i]), to[i]));
		worst = e > worst ? e : worst;
	}
	return worst;
}

/* ---- running it ---- */

static lo_server_thread start_receiver(int *port)
{
	lo_server_thread st = lo_server_thread_new(NULL, NULL); /* a free UDP port */
	if (!st)
		return NULL;
	lo_server_add_bundle_handlers(lo_server_thread_get_server(st), on_bundle_start, on_bundle_end, NULL);
	lo_server_thread_add_method(st, NULL, NULL, on_message, NULL);
	lo_server_thread_start(st);
	*port = lo_server_thread_get_port(st);
	rx.n = 0;
	return st;
}

/* Subscribes to every frame in rig space and keeps them while mocap-vmc
 * runs; its exit status. */
static int collect(const char *sock, const char *const *vmc_args, const char *out)
{
	mocap_client *c = mocap_connect(sock, "test_mocap_vmc");
	CHECK_MSG(c, "connect %s: %s", sock, mocap_errmsg());
	if (!c)
		return -1;
	CHECK(mocap_subscribe(c, MOCAP_ALL, MOCAP_SPACE_RIG, 0) == 0);
	CHECK(mocap_get_skeleton(c, &sk) == 0);
	pid_t pid = mcd_spawn(vmc_bin, vmc_args, out);
	nframes = 0;
	int rc = -1;
	uint64_t end = mcd_now_ms() + 60000;
	while (mcd_now_ms() < end) {
		int st;
		if (waitpid(pid, &st, WNOHANG) == pid) {
			rc = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
			break;
		}
		if (mocap_read_frame(c, &frames[nframes % MAX_FRAMES], 50) == 1)
			nframes++;
	}
	if (rc < 0)
		rc = mcd_wait_pid(pid, 0);
	mocap_close(c);
	mcd_sleep_ms(100); /* the last datagrams */
	return rc;
}

/* Each bundle whole and on one published frame within 1 mm. */
static void check_bundles(const char *what, bool zup_world, int want_bones, int want_bundles)
{
	pthread_mutex_lock(&rx.lock);
	int n = rx.n;
	pthread_mutex_unlock(&rx.lock);
	CHECK_MSG(n >= want_bundles, "%s: %d bundles received, %d sent", what, n, want_bundles);
	CHECK_MSG(nframes > 0 && nframes <= MAX_FRAMES, "%s: %d frames", what, nframes);
	double worst = 0;
	for (int i = 0; i < n; i++) {
		const bundle *b = &rx.b[i];
		CHECK_MSG(b->roots == 1 && b->oks == 1 && b->times == 1 && b->unknown == 0,
			  "%s: bundle %d: root %d, OK %d, T %d, unknown %d", what, i, b->roots, b->oks, b->times, b->unknown);
		double best = 1e9;
		int nb = 0;
		for (int k = 0; k < nframes && k < MAX_FRAMES; k++) {
			double e = miss(b, &frames[k], zup_world, &nb);
			best = e < best ? e : best;
		}
		CHECK_MSG(nb == want_bones, "%s: bundle %d has %d bones, expected %d", what, i, nb, want_bones);
		CHECK_MSG(best < 1e-3, "%s: bundle %d is %.2f mm from every published frame", what, i, best * 1e3);
		worst = best > worst ? best : worst;
	}
	printf("%s: %d bundles, %d frames published meanwhile; largest miss of a bundle's forward kinematics "
	       "against its frame: %.3f mm\n",
	       what, n, nframes, worst * 1e3);
}

static void test_testpub(void)
{
	char dir[] = "/tmp/test-mocap-vmc-XXXXXX", sock[128], out[128], vout[128], port[16];
	if (!mkdtemp(dir))
		return;
	snprintf(sock, sizeof(sock), "%s/pub.sock", dir);
	snprintf(out, sizeof(out), "%s/testpub.txt", dir);
	snprintf(vout, sizeof(vout), "%s/vmc.txt", dir);
	const char *const pub_args[] = {"--socket", sock, "--rate", "60", NULL};
	pid_t pub = mcd_spawn(testpub_bin, pub_args, out);
	for (int i = 0; i < 500 && !mcd_can_connect(sock); i++)
		mcd_sleep_ms(10);
	int oport = 0;
	lo_server_thread rxs = start_receiver(&oport);
	CHECK(rxs != NULL);
	snprintf(port, sizeof(port), "%d", oport);
	char target[32];
	snprintf(target, sizeof(target), "127.0.0.1:%s", port);
	const char *const vmc_args[] = {"--socket", sock, "--target", target, "--frames", "40", "--quiet", NULL};
	int rc = collect(sock, vmc_args, vout);
	CHECK_MSG(rc == 0, "mocap-vmc exited %d", rc);
	/* testpub has no head joint: 17 bones, on an outside-in rig (z up) */
	check_bundles("mocap-testpub (pelvis root, z-up world)", true, 17, 40);
	char *log = mcd_read_file(vout);
	CHECK_MSG(log && strstr(log, "40 bundles sent"), "mocap-vmc said: %s", log ? log : "");
	free(log);
	/* A set rate: 10 bundles at 20 per second from a 60 fps source take
	 * at least 9 periods. */
	pthread_mutex_lock(&rx.lock);
	rx.n = 0;
	pthread_mutex_unlock(&rx.lock);
	const char *const rate_args[] = {"--socket", sock, "--port", port, "--rate", "20", "--frames", "10", NULL};
	uint64_t t0 = mcd_now_ms();
	rc = collect(sock, rate_args, vout);
	uint64_t took = mcd_now_ms() - t0;
	CHECK_MSG(rc == 0 && took >= 450, "mocap-vmc --rate 20 --frames 10: exit %d after %llu ms", rc,
		  (unsigned long long)took);
	check_bundles("mocap-testpub at --rate 20", true, 17, 10);
	/* A bad bone file: exit 2 naming the file and the key. */
	char bones[160];
	snprintf(bones, sizeof(bones), "%s/bones.ini", dir);
	FILE *fp = fopen(bones, "w");
	if (fp) {
		fputs("[bones]\nLeftUpperArm = left_arm\nSpine = spine chest\n", fp);
		fclose(fp);
	}
	const char *const bad_args[] = {"--socket", sock, "--port", port, "--bones", bones, "--frames", "1", NULL};
	rc = mcd_wait_pid(mcd_spawn(vmc_bin, bad_args, vout), 20000);
	log = mcd_read_file(vout);
	CHECK_MSG(rc == 2 && log && strstr(log, "bones.ini: bones: Spine: the skeleton has no joint 'chest'"),
		  "exit %d: %s", rc, log ? log : "");
	free(log);
	lo_server_thread_free(rxs);
	kill(pub, SIGTERM);
	CHECK(mcd_wait_pid(pub, 10000) == 0);
	char cmd[64];
	snprintf(cmd, sizeof(cmd), "rm -rf %s", dir);
	CHECK(system(cmd) == 0);
}

/* mocapd on the bundled clip, in the head rig's frame (no head pose). */
static void test_daemon(void)
{
	if (!mcd_find_build_up(3)) {
		printf("SKIP part: mocapd is not built\n");
		return;
	}
	mcd_run r;
	CHECK(mcd_run_init(&r));
	static char conf[65536];
	mcd_demo_clip_config(conf, sizeof(conf), repo, 15, "", "", NULL, "");
	mcd_run_config(&r, conf);
	const char *const args[] = {NULL};
	if (!mcd_run_start_ready(&r, args))
		return;
	int oport = 0;
	lo_server_thread rxs = start_receiver(&oport);
	char port[16];
	snprintf(port, sizeof(port), "%d", oport);
	const char *const vmc_args[] = {"--socket", r.sock, "--port", port,         "--frames", "20",
					"--set",  "min_confidence=0", "--quiet", NULL};
	char vout[160];
	snprintf(vout, sizeof(vout), "%s/vmc.txt", r.dir);
	int rc = collect(r.sock, vmc_args, vout);
	CHECK_MSG(rc == 0, "mocap-vmc exited %d", rc);
	check_bundles("mocapd demo (head root, head rig frame)", false, 18, 20);
	/* Upright, the head 1.6 m over the floor (the rig frame's default),
	 * and the T-pose: the left forearm's rest offset along Unity -x. */
	for (int i = 0; i < rx.n; i++) {
		mc_vec3 u[NEXPECT];
		unity_fk(&rx.b[i], u);
		CHECK_MSG(u[3].y > u[0].y + 0.3 && u[0].y > u[12].y + 0.3, "bundle %d: head %.2f hips %.2f ankle %.2f", i,
			  u[3].y, u[0].y, u[12].y);
		CHECK_MSG(fabs(u[3].y - 1.6) < 0.3, "bundle %d: head at %.2f m", i, u[3].y);
		mc_vec3 fore = rx.b[i].pos[5];
		CHECK_MSG(fore.x < -0.2 && fabs(fore.y) < 1e-4 && fabs(fore.z) < 1e-4, "LeftLowerArm at (%.3f %.3f %.3f)",
			  fore.x, fore.y, fore.z);
	}
	lo_server_thread_free(rxs);
	/* The daemon gone: exit 1, saying so. */
	mcd_run_signal(&r, SIGTERM);
	CHECK(mcd_run_wait_exit(&r, 20000) == 0);
	const char *const gone_args[] = {"--socket", r.sock, "--port", port, NULL};
	rc = mcd_wait_pid(mcd_spawn(vmc_bin, gone_args, vout), 20000);
	char *log = mcd_read_file(vout);
	CHECK_MSG(rc == 1 && log && strstr(log, "cannot connect to mocapd"), "exit %d: %s", rc, log ? log : "");
	free(log);
	if (mc_test_failures)
		mcd_run_dump(&r, "mocap-vmc test");
	mcd_run_cleanup(&r);
}

static void test_usage(void)
{
	static const struct {
		const char *args[4];
		const char *says;
	} cases[] = {
		{{"--port", "0"}, "mocap-vmc: port: '0': expected a UDP port"},
		{{"--target", "localhost"}, "mocap-vmc: target: 'localhost': expected HOST:PORT"},
		{{"--set", "rest=relaxed"}, "mocap-vmc: rest: 'relaxed': expected tpose or model"},
		{{"--config", "/nonexistent/vmc.conf"}, "/nonexistent/vmc.conf: cannot open the config file"},
		{{"stray"}, "unexpected argument 'stray'"},
	};
	char out[] = "/tmp/test-mocap-vmc-usage.txt";
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		int rc = mcd_wait_pid(mcd_spawn(vmc_bin, cases[i].args, out), 10000);
		char *log = mcd_read_file(out);
		CHECK_MSG(rc == 2 && log && strstr(log, cases[i].says), "case %zu: exit %d: %s", i, rc, log ? log : "");
		free(log);
	}
	unlink(out);
}

int main(void)
{
	char build[PATH_MAX];
	if (!mc_test_build_dir(3, build, sizeof(build))) /* <build>/vmc/tests/test_mocap_vmc */
		TEST_SKIP("cannot find the build folder");
	snprintf(vmc_bin, sizeof(vmc_bin), "%s/bin/mocap-vmc", build);
	snprintf(testpub_bin, sizeof(testpub_bin), "%s/ipc/mocap-testpub", build);
	if (access(vmc_bin, X_OK) != 0 || access(testpub_bin, X_OK) != 0)
		TEST_SKIP("mocap-vmc or mocap-testpub is not built");
	if (!getcwd(repo, sizeof(repo)) || access("tests/data/ego_demo/gt.json", R_OK) != 0)
		TEST_SKIP("run from the repository root (tests/data/ego_demo not found)");
	signal(SIGPIPE, SIG_IGN);
	test_usage();
	test_testpub();
	test_daemon();
	return mc_test_finish("test_mocap_vmc");
}
