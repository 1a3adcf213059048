/* mocapd's config parser: every value type, every refusal, and the exact
 * "file:line: [section] key: why" form of the messages. */
#include "config.h"
#include "motion/mc_motion_graph.h"
#include "log.h"
#include "network.h"
#include "base/mc_one_euro.h"
#include "test_util.h"

#include <signal.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

static mcd_config cfg;

static int parse(const char *text, mc_err *err)
{
	memset(err, 0, sizeof(*err));
	return mcd_config_parse(text, "mocapd.conf", "/etc/mocapd", &cfg, err);
}

/* Parses text, expects failure with exactly `want` as the message. */
static void expect_error(const char *text, const char *want)
{
	mc_err err;
	int rc = parse(text, &err);
	CHECK_MSG(rc == -1, "accepted: %s", text);
	CHECK_MSG(strcmp(err.msg, want) == 0, "\n  got  '%s'\n  want '%s'", err.msg, want);
}

#define CAM "[camera left]\ndriver = faulty\n"
#define NOTRACK "[tracker]\nenabled = false\n"

static void test_full_config(void)
{
	const char *text = "; mocapd test config\n"
			   "# comments both ways\n"
			   "[daemon]\n"
			   "plugin_dir = drivers\n"
			   "log_level = debug\n"
			   "print = yes\n"
			   "group_tolerance_ms = 4.5\n"
			   "group_deadline_ms = 80\n"
			   "reopen_initial_ms = 100\n"
			   "reopen_max_ms = 5000\n"
			   "\n"
			   "[camera left]\n"
			   "driver = files\n"
			   "rig_camera = left\n"
			   "path = /data/left/%05d.jpg   ; inline comment\n"
			   "fps = 30\n"
			   "\n"
			   "[camera right]\n"
			   "driver = files\n"
			   "rig_camera = right\n"
			   "ring_slots = 16\n"
			   "path = right\n"
			   "calib_path = calib/r.txt\n"
			   "device = cam0\n"
			   "[tracker]\n"
			   "rig = rigs/ego.json\n"
			   "rig_format = ego-calib\n"
			   "model = /usr/share/mocapd/models/human.json\n"
			   "init_joints = gt.json\n"
			   "width = 64\n"
			   "height = 48\n"
			   "iterations = 20\n"
			   "pixel_fraction = 0.25\n"
			   "dropout = 0.5\n"
			   "lambda_detection = 2\n"
			   "backend = reference\n"
			   "opencl_platform = 0\n"
			   "opencl_device = auto\n"
			   "seed = 42\n"
			   "[socket]\n"
			   "path = /run/mocapd/test.sock\n"
			   "group = video\n"
			   "mode = 0666\n"
			   "max_clients = 4\n";
	mc_err err;
	int rc = parse(text, &err);
	CHECK_MSG(rc == 0, "%s", err.msg);
	CHECK(strcmp(cfg.plugin_dir, "/etc/mocapd/drivers") == 0);
	CHECK(cfg.log_level == MCD_LOG_DEBUG);
	CHECK(cfg.print);
	CHECK_NEAR(cfg.group_tolerance_ms, 4.5, 0);
	CHECK_NEAR(cfg.group_deadline_ms, 80, 0);
	CHECK_NEAR(cfg.reopen_initial_ms, 100, 0);
	CHECK_NEAR(cfg.reopen_max_ms, 5000, 0);
	CHECK(cfg.ncams == 2);
	CHECK(strcmp(cfg.cams[0].name, "left") == 0);
	CHECK(strcmp(cfg.cams[0].driver, "files") == 0);
	CHECK(cfg.cams[0].driver_line == 13);
	CHECK(cfg.cams[0].nkeys == 2);
	const mcd_kv *kv = mcd_camera_config_find(&cfg.cams[0], "path");
	CHECK(kv && strcmp(kv->value, "/data/left/%05d.jpg") == 0 && kv->line == 15);
	kv = mcd_camera_config_find(&cfg.cams[1], "path");
	CHECK(kv && strcmp(kv->value, "/etc/mocapd/right") == 0); /* relative to the config */
	kv = mcd_camera_config_find(&cfg.cams[1], "calib_path");
	CHECK(kv && strcmp(kv->value, "/etc/mocapd/calib/r.txt") == 0);
	kv = mcd_camera_config_find(&cfg.cams[1], "device");
	CHECK(kv && strcmp(kv->value, "cam0") == 0); /* other driver keys verbatim */
	CHECK(cfg.cams[0].ring_slots == 8);
	CHECK(cfg.cams[1].ring_slots == 16);
	CHECK(strcmp(cfg.cams[1].rig_camera, "right") == 0);
	CHECK(!mcd_camera_config_find(&cfg.cams[1], "fps"));
	CHECK(cfg.tracker.enabled);
	CHECK(strcmp(cfg.tracker.rig, "/etc/mocapd/rigs/ego.json") == 0);
	CHECK(cfg.tracker.rig_format == MCD_RIG_EGO_CALIB);
	CHECK(strcmp(cfg.tracker.model, "/usr/share/mocapd/models/human.json") == 0);
	CHECK(strcmp(cfg.tracker.init_joints, "/etc/mocapd/gt.json") == 0);
	const mc_tracker_settings *ts = &cfg.tracker.settings;
	mc_tracker_settings def;
	mc_tracker_settings_default(&def);
	CHECK(ts->width == 64 && ts->height == 48 && ts->iterations == 20);
	CHECK_NEAR(ts->pixel_fraction, 0.25, 0);
	CHECK_NEAR(ts->dropout, 0.5, 0);
	CHECK(ts->step == def.step); /* not given: the tracker's default */
	CHECK_NEAR(ts->lambda_detection, 2, 0);
	CHECK(ts->lambda_smooth == def.lambda_smooth);
	CHECK(ts->backend == MC_BACKEND_REFERENCE);
	CHECK(ts->cl_platform == 0 && ts->cl_device == -1);
	CHECK(ts->seed == 42);
	CHECK(strcmp(cfg.socket.path, "/run/mocapd/test.sock") == 0);
	CHECK(strcmp(cfg.socket.group, "video") == 0);
	CHECK(cfg.socket.mode == 0666 && cfg.socket.max_clients == 4);

	char where[256];
	CHECK(strcmp(mcd_config_where(&cfg, "tracker", "rig", where, sizeof(where)), "mocapd.conf:26: [tracker] rig") ==
	      0);
	CHECK(strcmp(mcd_config_where(&cfg, "tracker", "step", where, sizeof(where)), "mocapd.conf: [tracker] step") ==
	      0);
	CHECK(strcmp(mcd_config_where(&cfg, "camera right", "path", where, sizeof(where)),
		     "mocapd.conf:22: [camera right] path") == 0);
}

static void test_defaults(void)
{
	mc_err err;
	CHECK_MSG(parse(CAM NOTRACK, &err) == 0, "%s", err.msg);
	CHECK(strcmp(cfg.socket.path, "/run/mocapd/mocapd.sock") == 0);
	CHECK(cfg.log_level == MCD_LOG_INFO);
	CHECK(!cfg.print);
	CHECK(cfg.reopen_initial_ms > 0 && cfg.reopen_max_ms >= cfg.reopen_initial_ms);
	CHECK(cfg.group_deadline_ms > 0);
	CHECK(!cfg.tracker.enabled);
	mc_tracker_settings def;
	mc_tracker_settings_default(&def);
	CHECK(memcmp(&cfg.tracker.settings, &def, sizeof(def)) == 0); /* the tracker's defaults */
	/* CRLF line ends are fine. */
	CHECK_MSG(parse("[camera a]\r\ndriver = x\r\n[tracker]\r\nenabled = off\r\n", &err) == 0, "%s", err.msg);
	CHECK(strcmp(cfg.cams[0].driver, "x") == 0);
	/* The output filter is off unless asked for; its parameters are
	 * those of mc_one_euro_params_default. */
	CHECK(cfg.output.filter == MCD_FILTER_NONE);
	mc_one_euro_params one;
	mc_one_euro_params_default(&one);
	CHECK(cfg.output.min_cutoff_hz == one.min_cutoff_hz && cfg.output.beta == one.beta &&
	      cfg.output.d_cutoff_hz == one.d_cutoff_hz && cfg.output.max_gap_ms == 200);
	CHECK_MSG(parse(CAM NOTRACK "[output]\nfilter = one_euro\nfilter_beta = 0\n", &err) == 0, "%s", err.msg);
	CHECK(cfg.output.filter == MCD_FILTER_ONE_EURO && cfg.output.beta == 0);
}

static void test_value_errors(void)
{
	expect_error(CAM "[tracker]\nrig = r.json\nmodel = m.json\niterations = abc\n",
		     "mocapd.conf:6: [tracker] iterations: expected a positive integer, got 'abc'");
	expect_error(CAM NOTRACK "iterations = 0\n",
		     "mocapd.conf:5: [tracker] iterations: expected a positive integer, got '0'");
	expect_error(CAM NOTRACK "iterations = 12x\n",
		     "mocapd.conf:5: [tracker] iterations: expected a positive integer, got '12x'");
	expect_error(CAM NOTRACK "iterations = 99999999999999999999\n",
		     "mocapd.conf:5: [tracker] iterations: expected a positive integer, got '99999999999999999999'");
	expect_error(CAM NOTRACK "width = 9000\n",
		     "mocapd.conf:5: [tracker] width: expected an integer from 1 to 8192, got '9000'");
	expect_error(CAM NOTRACK "pixel_fraction = 1.5\n",
		     "mocapd.conf:5: [tracker] pixel_fraction: expected a number above 0 and at most 1, got '1.5'");
	expect_error(CAM NOTRACK "pixel_fraction = nan\n",
		     "mocapd.conf:5: [tracker] pixel_fraction: expected a number above 0 and at most 1, got 'nan'");
	expect_error(CAM NOTRACK "lambda_detection = -1\n",
		     "mocapd.conf:5: [tracker] lambda_detection: expected a number from 0 to 1000, got '-1'");
	expect_error(CAM NOTRACK "dropout = -0.1\n",
		     "mocapd.conf:5: [tracker] dropout: expected a number from 0 to 0.99, got '-0.1'");
	expect_error(CAM NOTRACK "backend = cuda\n",
		     "mocapd.conf:5: [tracker] backend: expected opencl or reference, got 'cuda'");
	expect_error(CAM NOTRACK "opencl_device = gpu\n",
		     "mocapd.conf:5: [tracker] opencl_device: expected auto or an index from 0 to 63, got 'gpu'");
	expect_error(CAM "[tracker]\nenabled = maybe\n",
		     "mocapd.conf:4: [tracker] enabled: expected true or false, got 'maybe'");
	expect_error("[daemon]\nlog_level = loud\n" CAM NOTRACK,
		     "mocapd.conf:2: [daemon] log_level: expected error, warn, info or debug, got 'loud'");
	expect_error("[daemon]\ngroup_deadline_ms = 0\n" CAM NOTRACK,
		     "mocapd.conf:2: [daemon] group_deadline_ms: expected a number above 0 and at most 10000, got '0'");
	expect_error("[daemon]\nreopen_initial_ms = 500\nreopen_max_ms = 100\n" CAM NOTRACK,
		     "mocapd.conf:3: [daemon] reopen_max_ms: must be at least reopen_initial_ms (500)");
	expect_error(CAM NOTRACK "[socket]\nmode = 660\n",
		     "mocapd.conf:6: [socket] mode: expected an octal mode such as 0660, got '660'");
	expect_error(CAM NOTRACK "[socket]\ngroup = a b\n",
		     "mocapd.conf:6: [socket] group: expected a name of letters, digits, '_' and '-', got 'a b'");
	expect_error(CAM NOTRACK "[socket]\nmax_clients = 0\n",
		     "mocapd.conf:6: [socket] max_clients: expected an integer from 1 to 1024, got '0'");
	expect_error(CAM NOTRACK "[socket]\npath = /run/mocapd/"
				 "aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa\n",
		     "mocapd.conf:6: [socket] path: path too long (at most 107 bytes)");
	expect_error("[camera left]\ndriver = ../evil\n" NOTRACK,
		     "mocapd.conf:2: [camera left] driver: expected a name of letters, digits, '_' and '-', got '../evil'");
	expect_error(CAM "ring_slots = 1\n" NOTRACK,
		     "mocapd.conf:3: [camera left] ring_slots: expected an integer from 2 to 1024, got '1'");
	expect_error(CAM NOTRACK "rig =\n", "mocapd.conf:5: [tracker] rig: expected a path, got nothing");
	expect_error(CAM NOTRACK "[output]\nfilter = kalman\n",
		     "mocapd.conf:6: [output] filter: expected none or one_euro, got 'kalman'");
	expect_error(CAM NOTRACK "[output]\nfilter = one_euro\nfilter_min_cutoff_hz = 0\n",
		     "mocapd.conf:7: [output] filter_min_cutoff_hz: expected a number above 0 and at most 1000, got '0'");
	expect_error(CAM NOTRACK "[output]\nfilter_d_cutoff_hz = 2000\n",
		     "mocapd.conf:6: [output] filter_d_cutoff_hz: expected a number above 0 and at most 1000, got '2000'");
	expect_error(CAM NOTRACK "[output]\nfilter_beta = -1\n",
		     "mocapd.conf:6: [output] filter_beta: expected a number from 0 to 1000, got '-1'");
	expect_error(CAM NOTRACK "[output]\nfilter_max_gap_ms = 0\n",
		     "mocapd.conf:6: [output] filter_max_gap_ms: expected a number above 0 and at most 10000, got '0'");
}

static void test_structure_errors(void)
{
	expect_error(CAM NOTRACK "iteratons = 5\n",
		     "mocapd.conf:5: [tracker] iteratons: unknown key (did you mean 'iterations'?)");
	expect_error("[daemon]\nplugins = /x\n" CAM NOTRACK, "mocapd.conf:2: [daemon] plugins: unknown key");
	expect_error("[deamon]\nlog_level = info\n" CAM NOTRACK, "mocapd.conf:1: unknown section [deamon] (did you mean [daemon]?)");
	expect_error("[cameras left]\n" CAM NOTRACK, "mocapd.conf:1: unknown section [cameras left] (did you mean [camera NAME]?)");
	expect_error("[foo]\n" CAM NOTRACK,
		     "mocapd.conf:1: unknown section [foo] (expected [daemon], [camera NAME], [tracker], [socket], [detector], [network], [record], [source] or [output])");
	expect_error("log_level = info\n" CAM NOTRACK,
		     "mocapd.conf:1: log_level: key outside any section (start with [daemon])");
	expect_error(CAM NOTRACK "enabled = true\n",
		     "mocapd.conf:5: [tracker] enabled: given twice (first at line 4)");
	expect_error(CAM "path = a\npath = b\n" NOTRACK,
		     "mocapd.conf:4: [camera left] path: given twice (first at line 3)");
	expect_error(CAM NOTRACK "[tracker]\n", "mocapd.conf:5: section [tracker] given twice (first at line 3)");
	expect_error(CAM CAM NOTRACK, "mocapd.conf:3: section [camera left] given twice (first at line 1)");
	expect_error("[camera]\ndriver = x\n" NOTRACK, "mocapd.conf:1: [camera] needs a name: [camera NAME]");
	expect_error("[camera a/b]\ndriver = x\n" NOTRACK,
		     "mocapd.conf:1: [camera a/b]: a camera name is letters, digits, '_' and '-', at most 63 bytes");
	expect_error(CAM NOTRACK "  iterations = 5\n",
		     "mocapd.conf:5: indented line (inih reads it as the continuation of the previous value); "
		     "remove the indentation");
	expect_error(CAM NOTRACK "iterations 5\n",
		     "mocapd.conf:5: syntax error (expected [section] or key = value)");
	/* A duplicate after as many keys as a file can hold is still caught
	 * (issue 20, defect 6: the 161st key and after went unchecked). */
	static char many[1 << 16];
	size_t len = 0;
	for (int c = 0; c < MC_MAX_CAMERAS; c++) {
		len += (size_t)snprintf(many + len, sizeof(many) - len, "[camera c%d]\ndriver = faulty\n", c);
		for (int k = 0; k < MCD_MAX_DRIVER_KEYS; k++)
			len += (size_t)snprintf(many + len, sizeof(many) - len, "k%d = 1\n", k);
	}
	int line = 1 + MC_MAX_CAMERAS * (2 + MCD_MAX_DRIVER_KEYS) + 3;
	snprintf(many + len, sizeof(many) - len, NOTRACK "[socket]\nmode = 0600\nmode = 0666\n");
	char want[200];
	snprintf(want, sizeof(want), "mocapd.conf:%d: [socket] mode: given twice (first at line %d)", line + 1, line);
	expect_error(many, want);
	/* A UTF-8 byte order mark before the first section is not a key. */
	mc_err err;
	CHECK_MSG(parse("\xEF\xBB\xBF" CAM NOTRACK, &err) == 0, "with a BOM: %s", err.msg);
	char longline[400];
	snprintf(longline, sizeof(longline), CAM NOTRACK "rig = %0300d\n", 0);
	expect_error(longline, "mocapd.conf:5: line too long (at most 198 characters)");
}

static void test_cross_checks(void)
{
	expect_error(NOTRACK, "mocapd.conf: no [camera NAME] section; at least one camera is needed (or a [source] graph)");
	expect_error("[camera left]\nfps = 30\n" NOTRACK, "mocapd.conf:1: [camera left]: missing key 'driver'");
	expect_error(CAM, "mocapd.conf: no [tracker] section (give rig and model, or enabled = false)");
	expect_error(CAM "rig_camera = l\n[tracker]\nmodel = m.json\n", "mocapd.conf:4: [tracker]: missing key 'rig'");
	expect_error(CAM "rig_camera = l\n[tracker]\nrig = r.json\n", "mocapd.conf:4: [tracker]: missing key 'model'");
	expect_error(CAM "[tracker]\nrig = r.json\nmodel = m.json\n",
		     "mocapd.conf:1: [camera left]: missing key 'rig_camera' (which rig camera this is; needed while "
		     "the tracker is enabled)");
	expect_error("[camera a]\ndriver = x\nrig_camera = left\n[camera b]\ndriver = x\nrig_camera = left\n"
		     "[tracker]\nrig = r.json\nmodel = m.json\n",
		     "mocapd.conf:6: [camera b] rig_camera: 'left' is already taken by [camera a] (line 3)");
}

/* [source] graph: instead of cameras and tracker (docs/MOTION_GRAPH.md). */
static void test_source(void)
{
	mc_err err;
	CHECK_MSG(parse("[source]\ngraph = walks.mg\nrate = 60\ngraph_kind = motion\nseed = 9\n", &err) == 0, "%s",
		  err.msg);
	CHECK(strcmp(cfg.source.graph, "/etc/mocapd/walks.mg") == 0 && cfg.source.rate == 60 &&
	      cfg.source.kind == MC_EDGE_MOTION && cfg.source.seed == 9 && !cfg.tracker.enabled && cfg.ncams == 0);
	CHECK(parse("[source]\ngraph = walks.mg\n", &err) == 0 && cfg.source.rate == 30 &&
	      cfg.source.kind == MC_EDGE_ESSENTIAL && cfg.source.seed == 1);
	expect_error(CAM "[source]\ngraph = walks.mg\n",
		     "mocapd.conf:1: [camera left]: [source] graph replaces the cameras; remove one or the other");
	expect_error("[tracker]\nrig = r.json\nmodel = m.json\n[source]\ngraph = walks.mg\n",
		     "mocapd.conf:1: [tracker]: [source] graph replaces the tracker; remove one or the other");
	CHECK(parse("[source]\ngraph = walks.mg\ngraph_kind = best\n", &err) == -1 && strstr(err.msg, "graph_kind"));
	CHECK(parse("[source]\ngraph = walks.mg\nrate = 0\n", &err) == -1 && strstr(err.msg, "rate"));
	/* no graph: cameras as usual */
	CHECK(parse(CAM NOTRACK "[source]\nrate = 60\n", &err) == 0 && !cfg.source.graph[0]);
}

static void test_load_file(void)
{
	mc_err err;
	CHECK(mcd_config_load("/nonexistent/mocapd.conf", &cfg, &err) == -1);
	CHECK(strcmp(err.msg, "/nonexistent/mocapd.conf: cannot open: No such file or directory") == 0);

	char dir[] = "/tmp/mocapd-config-XXXXXX";
	CHECK(mkdtemp(dir) != NULL);
	char path[256];
	snprintf(path, sizeof(path), "%s/test.conf", dir);
	FILE *f = fopen(path, "w");
	CHECK(f != NULL);
	if (!f)
		return;
	fputs("[daemon]\nplugin_dir = plugins\n[camera c]\ndriver = d\n[tracker]\nenabled = false\n", f);
	fclose(f);
	CHECK_MSG(mcd_config_load(path, &cfg, &err) == 0, "%s", err.msg);
	char want[600];
	snprintf(want, sizeof(want), "%s/plugins", dir);
	CHECK(strcmp(cfg.plugin_dir, want) == 0);
	CHECK(strcmp(cfg.file, path) == 0);

	f = fopen(path, "w");
	fputs("[daemon]\nlog_level = shouting\n", f);
	fclose(f);
	CHECK(mcd_config_load(path, &cfg, &err) == -1);
	snprintf(want, sizeof(want), "%s:2: [daemon] log_level: expected error, warn, info or debug, got 'shouting'",
		 path);
	CHECK_MSG(strcmp(err.msg, want) == 0, "%s", err.msg);

	f = fopen(path, "w");
	fwrite("[daemon]\n\0\n", 1, 11, f);
	fclose(f);
	CHECK(mcd_config_load(path, &cfg, &err) == -1);
	CHECK(strstr(err.msg, "NUL byte") != NULL);
	unlink(path);
	rmdir(dir);
}

/* --check lists every error of the file, not only the first (issue 31
 * item 6), with "did you mean" for keys and sections; err keeps the first. */
static void test_all_errors(void)
{
	char buf[4096];
	mcd_config_errors all = {.buf = buf, .cap = sizeof(buf)};
	mc_err err;
	const char *text = "[daemon]\nlog_levl = info\n"
			   "[trakcer]\nrig = x\n"
			   "[camera a]\ndriver = files\nrig_camera = a\n"
			   "  indented = 1\n"
			   "[tracker]\nrig = r.json\nmodel = m.json\niteration = 5\nwidth = 99999\n";
	CHECK(mcd_config_parse_all(text, "m.conf", "/etc/mocapd", &cfg, &all, &err) == -1);
	CHECK_MSG(strcmp(err.msg, "m.conf:2: [daemon] log_levl: unknown key (did you mean 'log_level'?)") == 0, "%s",
		  err.msg);
	const char *want = "m.conf:2: [daemon] log_levl: unknown key (did you mean 'log_level'?)\n"
			   "m.conf:3: unknown section [trakcer] (did you mean [tracker]?)\n"
			   "m.conf:8: indented line (inih reads it as the continuation of the previous value); remove "
			   "the indentation\n"
			   "m.conf:12: [tracker] iteration: unknown key (did you mean 'iterations'?)\n"
			   "m.conf:13: [tracker] width: expected an integer from 1 to 8192, got '99999'\n";
	CHECK_MSG(strcmp(buf, want) == 0 && all.n == 5 && all.untold == 0, "%d errors:\n%s", all.n, buf);

	/* the checks across keys: each one that fails */
	all = (mcd_config_errors){.buf = buf, .cap = sizeof(buf)};
	CHECK(mcd_config_parse_all("[camera a]\nrig_camera = a\n[tracker]\nrig = r.json\n[daemon]\nreopen_initial_ms = "
				   "500\nreopen_max_ms = 100\n",
				   "m.conf", "/etc/mocapd", &cfg, &all, &err) == -1);
	CHECK_MSG(all.n == 3 && strstr(buf, "missing key 'model'") && strstr(buf, "missing key 'driver'") &&
			  strstr(buf, "reopen_max_ms: must be at least"),
		  "%d errors:\n%s", all.n, buf);

	/* more than the buffer holds: counted */
	char small[100];
	all = (mcd_config_errors){.buf = small, .cap = sizeof(small)};
	CHECK(mcd_config_parse_all("[daemon]\nlog_levl = info\nplugins = x\nfoo = 1\n" CAM NOTRACK, "m.conf", "/", &cfg,
				   &all, &err) == -1);
	CHECK_MSG(all.n == 3 && all.untold == 2 && strlen(small) < sizeof(small), "%d, %d: %s", all.n, all.untold, small);
	/* and without a list, the first error stops, as before */
	CHECK(mcd_config_parse(text, "m.conf", "/etc/mocapd", &cfg, &err) == -1);
	CHECK(strstr(err.msg, "log_levl") != NULL);
}

/* A FIFO (or a device) as the config is refused at once: opening a FIFO
 * without a writer blocks, and `mocapd --check` hung for ever (issue 34).
 * Run in a child so that a hang shows as a failure, not a stuck test. */
static void test_load_not_regular(void)
{
	char dir[] = "/tmp/mocapd-config-XXXXXX";
	CHECK(mkdtemp(dir) != NULL);
	char path[256];
	snprintf(path, sizeof(path), "%s/fifo.conf", dir);
	CHECK(mkfifo(path, 0600) == 0);
	pid_t pid = fork();
	if (pid == 0) {
		mc_err err = {{0}};
		int rc = mcd_config_load(path, &cfg, &err);
		char want[400];
		snprintf(want, sizeof(want), "%s: not a regular file (a FIFO); refused", path);
		if (rc == -1 && strcmp(err.msg, want) != 0)
			fprintf(stderr, "got '%s'\n", err.msg);
		_exit(rc == -1 && strcmp(err.msg, want) == 0 ? 0 : 1);
	}
	int status = 0;
	bool done = false;
	for (int i = 0; i < 300 && !done; i++) {
		done = waitpid(pid, &status, WNOHANG) == pid;
		if (!done)
			usleep(10000);
	}
	if (!done) {
		kill(pid, SIGKILL);
		waitpid(pid, &status, 0);
	}
	CHECK_MSG(done, "mcd_config_load blocked on a FIFO for 3 s");
	CHECK_MSG(done && WIFEXITED(status) && WEXITSTATUS(status) == 0, "FIFO config not refused as expected");
	mc_err err = {{0}};
	CHECK(mcd_config_load(dir, &cfg, &err) == -1);
	char want[400];
	snprintf(want, sizeof(want), "%s: not a regular file (a directory); refused", dir);
	CHECK_MSG(strcmp(err.msg, want) == 0, "%s", err.msg);
	unlink(path);
	rmdir(dir);
}

/* The configs the project ships parse, and mean what they say. */
static void test_shipped_configs(void)
{
	mc_err err;
	if (access("config/demo.conf", R_OK) != 0) {
		printf("config/demo.conf not found (not run from the repository root); shipped configs not checked\n");
		return;
	}
	CHECK_MSG(mcd_config_load("config/demo.conf", &cfg, &err) == 0, "%s", err.msg);
	CHECK(cfg.ncams == 2 && cfg.tracker.enabled);
	CHECK(strcmp(cfg.tracker.rig, "config/rigs/ego_stereo.json") == 0);
	CHECK(access(cfg.tracker.rig, R_OK) == 0 && access(cfg.tracker.model, R_OK) == 0);
	CHECK(access(cfg.tracker.init_joints, R_OK) == 0);
	const mcd_kv *kv = mcd_camera_config_find(&cfg.cams[0], "path");
	CHECK(kv && access(kv->value, R_OK) == 0);

	/* mocapd.conf as make install writes it */
	FILE *f = fopen("config/mocapd.conf", "r");
	CHECK(f != NULL);
	if (!f)
		return;
	char text[8192];
	size_t n = fread(text, 1, sizeof(text) - 1, f);
	fclose(f);
	text[n] = 0;
	char installed[9000] = "";
	const char *rest = text, *at;
	while ((at = strstr(rest, "@DATADIR@"))) {
		strncat(installed, rest, (size_t)(at - rest));
		strcat(installed, "/usr/share/mocapd");
		rest = at + strlen("@DATADIR@");
	}
	strcat(installed, rest);
	CHECK_MSG(mcd_config_parse(installed, "mocapd.conf", "/etc/mocapd", &cfg, &err) == 0, "%s", err.msg);
	CHECK(cfg.ncams == 2 && strcmp(cfg.cams[0].driver, "v4l2") == 0);
	CHECK(strcmp(cfg.tracker.model, "/usr/share/mocapd/models/default.json") == 0);
	CHECK(strcmp(cfg.socket.path, "/run/mocapd/mocapd.sock") == 0);
	CHECK(strcmp(cfg.detector.model, "/usr/share/mocapd/models/ego_detector.onnx") == 0);
}

/* [detector]: no model by default; empty is none; auto or a number for
 * min_confidence; the table's ranges. */
static void test_detector(void)
{
	mc_err err;
	CHECK_MSG(parse(CAM NOTRACK, &err) == 0, "%s", err.msg);
	CHECK(cfg.detector.model[0] == 0 && cfg.detector.rate == 0 && cfg.detector.threads == 1);
	CHECK(cfg.detector.min_confidence < 0);
	CHECK_MSG(parse(CAM NOTRACK "[detector]\nmodel =\nrate = 7.5\nthreads = 2\nmin_confidence = 0.45\n", &err) == 0,
		  "%s", err.msg);
	CHECK(cfg.detector.model[0] == 0 && cfg.detector.rate == 7.5 && cfg.detector.threads == 2);
	CHECK_NEAR(cfg.detector.min_confidence, 0.45, 0);
	CHECK_MSG(parse(CAM NOTRACK "[detector]\nmodel = models/d.onnx\nmin_confidence = auto\n", &err) == 0, "%s",
		  err.msg);
	CHECK(strcmp(cfg.detector.model, "/etc/mocapd/models/d.onnx") == 0 && cfg.detector.min_confidence < 0);
	expect_error(CAM NOTRACK "[detector]\nmin_confidence = 2\n",
		     "mocapd.conf:6: [detector] min_confidence: expected auto or a number from 0 to 1, got '2'");
	expect_error(CAM NOTRACK "[detector]\nrate = -1\n",
		     "mocapd.conf:6: [detector] rate: expected a number from 0 to 1000, got '-1'");
	expect_error(CAM NOTRACK "[detector]\nthreads = 0\n",
		     "mocapd.conf:6: [detector] threads: expected an integer from 1 to 64, got '0'");
	expect_error(CAM NOTRACK "[detector]\nmodle = x.onnx\n",
		     "mocapd.conf:6: [detector] modle: unknown key (did you mean 'model'?)");
	/* A reload takes rate, threads and min_confidence, not the model. */
	static mcd_config cur, neu;
	CHECK(mcd_config_parse(CAM NOTRACK "[detector]\nmodel = a.onnx\nrate = 5\n", "mocapd.conf", "/etc/mocapd", &cur,
			       &err) == 0);
	CHECK(mcd_config_parse(CAM NOTRACK "[detector]\nmodel = b.onnx\nrate = 10\nthreads = 2\nmin_confidence = 0.5\n",
			       "mocapd.conf", "/etc/mocapd", &neu, &err) == 0);
	CHECK(mcd_config_take_reloadable(&cur, &neu, NULL, 0) == 1); /* model */
	CHECK(strcmp(cur.detector.model, "/etc/mocapd/a.onnx") == 0 && cur.detector.rate == 10);
	CHECK(cur.detector.threads == 2 && cur.detector.min_confidence == 0.5);
}

static void test_network(void)
{
	mc_err err;
	CHECK_MSG(parse(CAM NOTRACK, &err) == 0, "%s", err.msg);
	CHECK(cfg.network.listen[0] == 0 && !cfg.network.privileged);
	CHECK_MSG(parse(CAM NOTRACK "[network]\nlisten = [::]:7878\ntoken_file = tok\nprivileged = yes\n", &err) == 0,
		  "%s", err.msg);
	CHECK(strcmp(cfg.network.listen, "[::]:7878") == 0 && strcmp(cfg.network.token_file, "/etc/mocapd/tok") == 0 &&
	      cfg.network.privileged);
	expect_error(CAM NOTRACK "[network]\nlisten = 0.0.0.0:7878\n",
		     "mocapd.conf:6: [network] listen: needs token_file, a file with the access token TCP clients must "
		     "present (e.g. made with: head -c 24 /dev/urandom | base64 > FILE)");
	expect_error(CAM NOTRACK "[network]\nlisten = 7878\n",
		     "mocapd.conf:6: [network] listen: expected HOST:PORT (e.g. 0.0.0.0:7878, [::]:7878), got '7878'");
	expect_error(CAM NOTRACK "[network]\nlisten = ::1:7878\n",
		     "mocapd.conf:6: [network] listen: expected HOST:PORT (e.g. 0.0.0.0:7878, [::]:7878), got '::1:7878'");
	expect_error(CAM NOTRACK "[network]\nlisten = h:70000\n",
		     "mocapd.conf:6: [network] listen: expected HOST:PORT (e.g. 0.0.0.0:7878, [::]:7878), got 'h:70000'");

	/* The token file: private, 16..255 characters on its first line. */
	char dir[] = "/tmp/mc_net_XXXXXX", file[64], token[SRV_TOKEN_MAX];
	CHECK(mkdtemp(dir) != NULL);
	snprintf(file, sizeof(file), "%s/token", dir);
	char text[256];
	snprintf(text, sizeof(text), CAM NOTRACK "[network]\nlisten = 127.0.0.1:0\ntoken_file = %s\n", file);
	CHECK_MSG(parse(text, &err) == 0, "%s", err.msg);
	CHECK(mcd_network_read_token(&cfg, token, sizeof(token), &err) == -1 && strstr(err.msg, "No such file"));
	FILE *f = fopen(file, "w");
	fputs("short\n", f);
	fclose(f);
	chmod(file, 0600);
	CHECK(mcd_network_read_token(&cfg, token, sizeof(token), &err) == -1 && strstr(err.msg, "16 to 255"));
	f = fopen(file, "w");
	fputs("0123456789abcdefXYZ\nsecond line\n", f);
	fclose(f);
	CHECK(mcd_network_read_token(&cfg, token, sizeof(token), &err) == 0 && strcmp(token, "0123456789abcdefXYZ") == 0);
	chmod(file, 0644);
	CHECK(mcd_network_read_token(&cfg, token, sizeof(token), &err) == -1 &&
	      strstr(err.msg, "mocapd.conf:7: [network] token_file") && strstr(err.msg, "readable by every user"));
	srv_config sc = {0};
	chmod(file, 0640);
	CHECK(mcd_network_apply(&cfg, &sc, &err) == 0 && strcmp(sc.tcp_listen, "127.0.0.1:0") == 0 &&
	      strcmp(sc.tcp_token, "0123456789abcdefXYZ") == 0 && !sc.tcp_privileged);
	unlink(file);
	rmdir(dir);
}

/* A reload takes the keys the table marks reloadable and keeps the others. */
static void test_reload(void)
{
	static mcd_config cur, neu;
	mc_err err;
	const char *before = CAM "rig_camera = l\n[daemon]\ngroup_deadline_ms = 80\n[tracker]\nrig = r.json\n"
			     "model = m.json\niterations = 20\nseed = 1\n";
	const char *after = CAM "rig_camera = l\n[daemon]\ngroup_deadline_ms = 50\n[tracker]\nrig = r.json\n"
			    "model = m.json\niterations = 10\nseed = 2\n";
	CHECK_MSG(mcd_config_parse(before, "mocapd.conf", "/etc/mocapd", &cur, &err) == 0, "%s", err.msg);
	CHECK_MSG(mcd_config_parse(after, "mocapd.conf", "/etc/mocapd", &neu, &err) == 0, "%s", err.msg);
	CHECK(mcd_config_take_reloadable(&cur, &neu, NULL, 0) == 1); /* seed */
	CHECK_NEAR(cur.group_deadline_ms, 50, 0);
	CHECK(cur.tracker.settings.iterations == 10);
	CHECK(cur.tracker.settings.seed == 1);
	CHECK(mcd_config_take_reloadable(&cur, &cur, NULL, 0) == 0);
	/* a camera that changes is refused as a whole */
	CHECK_MSG(mcd_config_parse("[camera left]\ndriver = other\nrig_camera = l\n[tracker]\nrig = r.json\n"
				   "model = m.json\niterations = 10\nseed = 1\n[daemon]\ngroup_deadline_ms = 50\n",
				   "mocapd.conf", "/etc/mocapd", &neu, &err) == 0,
		  "%s", err.msg);
	CHECK(mcd_config_take_reloadable(&cur, &neu, NULL, 0) == 1);
	CHECK(strcmp(cur.cams[0].driver, "faulty") == 0);
}

int main(void)
{
	test_source();
	test_full_config();
	test_defaults();
	test_value_errors();
	test_structure_errors();
	test_cross_checks();
	test_load_file();
	test_load_not_regular();
	test_all_errors();
	test_shipped_configs();
	test_reload();
	test_detector();
	test_network();
	return mc_test_finish("test_daemon_config");
}
