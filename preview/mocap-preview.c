/* mocap-preview: a live view of mocapd in a web browser.  A client of the
 * daemon (the daemon serves no HTTP itself): it serves a page with each
 * camera's frames and the tracked skeleton and the model's Gaussians drawn
 * over them, a 3D view of the skeleton (three.js from the install), the
 * status and the recording controls, and pushes updates to the page as
 * Server-Sent Events.  docs/PREVIEW.md.
 *
 * The modules: preview_http (routes, files, the token), preview_hub (the
 * event stream), preview_link (the daemon), preview_render (frames and
 * overlay as JPEG), preview_status (the JSON the page reads). */
#include "base/mc_error.h"
#include "base/mc_parse.h"
#include "mc_install_paths.h" /* generated: MC_VERSION, MC_INSTALL_DATA_DIR */
#include "mocap.h"
#include "preview_http.h"
#include "preview_link.h"

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <getopt.h>
#include <limits.h>
#include <netdb.h>
#include <netinet/in.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/random.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#define DEFAULT_LISTEN "127.0.0.1:8089"
#define DEFAULT_WWW MC_INSTALL_DATA_DIR "/preview"
#define DEFAULT_THREE "/usr/share/javascript/three"
#define DEFAULT_MODEL MC_INSTALL_DATA_DIR "/models/default.json"
#define TOKEN_ENV "MOCAP_PREVIEW_TOKEN"
#define PREVIEW_NICE 10
#define RENDER_NICE 19

static volatile sig_atomic_t stop;
static void on_signal(int sig) { (void)sig; stop = 1; }

/* Exit codes: 1 the system failed us (address in use, ...), 2 bad usage. */
#define fail(code, ...) mc_fail_exit("mocap-preview", code, __VA_ARGS__)

static void usage(FILE *f)
{
	fprintf(f,
		"usage: mocap-preview [options]\n"
		"Serves a live view of mocapd to web browsers (docs/PREVIEW.md).\n"
		"\n"
		"  --socket PATH       the daemon's socket (default: $MOCAP_SOCKET, else %s)\n"
		"  --listen HOST:PORT  the HTTP address (default %s; [IPV6]:PORT; port 0: any free one)\n"
		"  --token-file FILE   the token for state changes: its first line; a missing FILE is\n"
		"                      created with a new random token (mode 0600).  Default: $%s,\n"
		"                      else a new random token, printed at start\n"
		"  --rate HZ           camera views per second and camera (default 10)\n"
		"  --width PIXELS      the largest width of a camera view (default 480)\n"
		"  --quality Q         JPEG quality 1..100 (default 75)\n"
		"  --model FILE        the body model, for the Gaussians' outlines (default %s;\n"
		"                      without it the skeleton alone is drawn)\n"
		"  --www DIR           the page's files (default %s)\n"
		"  --three DIR         three.js from libjs-three (default %s)\n"
		"  --quiet             only errors\n"
		"  -h, --help          this text\n"
		"  -V, --version       the version\n",
		MOCAP_DEFAULT_SOCKET, DEFAULT_LISTEN, TOKEN_ENV, DEFAULT_MODEL, DEFAULT_WWW, DEFAULT_THREE);
}

typedef struct {
	const char *socket, *listen, *token_file, *www, *three, *model;
	double rate;
	int width, quality;
	bool verbose, model_given;
} options;

static double number_arg(const char *opt, const char *s, double lo, double hi)
{
	double v;
	if (!mc_parse_double(s, &v) || !(v >= lo && v <= hi))
		fail(2, "%s %s: expected a number from %g to %g", opt, s, lo, hi);
	return v;
}

static void parse_options(int argc, char **argv, options *o)
{
	enum { O_SOCKET = 256, O_LISTEN, O_TOKEN_FILE, O_RATE, O_WIDTH, O_QUALITY, O_MODEL, O_WWW, O_THREE, O_QUIET };
	static const struct option opts[] = {
		{"socket", required_argument, NULL, O_SOCKET},   {"listen", required_argument, NULL, O_LISTEN},
		{"token-file", required_argument, NULL, O_TOKEN_FILE}, {"rate", required_argument, NULL, O_RATE},
		{"width", required_argument, NULL, O_WIDTH},     {"quality", required_argument, NULL, O_QUALITY},
		{"model", required_argument, NULL, O_MODEL},     {"www", required_argument, NULL, O_WWW},
		{"three", required_argument, NULL, O_THREE},     {"quiet", no_argument, NULL, O_QUIET},
		{"help", no_argument, NULL, 'h'},                {"version", no_argument, NULL, 'V'},
		{NULL, 0, NULL, 0},
	};
	int c;
	while ((c = getopt_long(argc, argv, "hV", opts, NULL)) != -1) {
		switch (c) {
		case O_SOCKET: o->socket = optarg; break;
		case O_LISTEN: o->listen = optarg; break;
		case O_TOKEN_FILE: o->token_file = optarg; break;
		case O_RATE: o->rate = number_arg("--rate", optarg, 0.1, 60); break;
		case O_WIDTH: o->width = (int)number_arg("--width", optarg, 32, 4096); break;
		case O_QUALITY: o->quality = (int)number_arg("--quality", optarg, 1, 100); break;
		case O_MODEL: o->model = optarg, o->model_given = true; break;
		case O_WWW: o->www = optarg; break;
		case O_THREE: o->three = optarg; break;
		case O_QUIET: o->verbose = false; break;
		case 'h': usage(stdout); exit(0);
		case 'V': printf("mocap-preview %s (libmocap %s)\n", MC_VERSION, MOCAP_LIB_VERSION); exit(0);
		default: usage(stderr); exit(2);
		}
	}
	if (optind < argc) {
		usage(stderr);
		fail(2, "unexpected argument '%s'", argv[optind]);
	}
}

/* ---- the listening socket ---- */

/* HOST:PORT or [IPV6]:PORT into host and port; false if malformed. */
static bool split_listen(const char *s, char *host, size_t hcap, char *port, size_t pcap)
{
	const char *colon;
	if (s[0] == '[') {
		const char *close = strchr(s, ']');
		if (!close || close[1] != ':')
			return false;
		snprintf(host, hcap, "%.*s", (int)(close - s - 1), s + 1);
		colon = close + 1;
	} else {
		colon = strrchr(s, ':');
		if (!colon || strchr(s, ':') != colon)
			return false;
		snprintf(host, hcap, "%.*s", (int)(colon - s), s);
	}
	snprintf(port, pcap, "%s", colon + 1);
	char *end = NULL;
	long p = strtol(port, &end, 10);
	return host[0] && port[0] && !*end && p >= 0 && p <= 65535;
}

/* Binds and listens; *port_out the port (a free one for port 0),
 * *loopback whether the address is a loopback one. */
static int listen_on(const char *spec, int *port_out, bool *loopback)
{
	char host[256], port[16];
	if (!split_listen(spec, host, sizeof(host), port, sizeof(port)))
		fail(2, "--listen %s: expected HOST:PORT (e.g. 127.0.0.1:8089, [::1]:8089)", spec);
	struct addrinfo hints = {.ai_family = AF_UNSPEC, .ai_socktype = SOCK_STREAM, .ai_flags = AI_PASSIVE}, *ai;
	int rc = getaddrinfo(host, port, &hints, &ai);
	if (rc != 0)
		fail(2, "--listen %s: %s", spec, gai_strerror(rc));
	int fd = socket(ai->ai_family, SOCK_STREAM | SOCK_CLOEXEC, 0);
	int one = 1;
	if (fd < 0 || setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one)) != 0 ||
	    bind(fd, ai->ai_addr, ai->ai_addrlen) != 0 || listen(fd, 32) != 0)
		fail(1, "--listen %s: %s", spec, strerror(errno));
	struct sockaddr_storage a;
	socklen_t alen = sizeof(a);
	getsockname(fd, (struct sockaddr *)&a, &alen);
	if (a.ss_family == AF_INET) {
		const struct sockaddr_in *in = (const struct sockaddr_in *)&a;
		*port_out = ntohs(in->sin_port);
		*loopback = (ntohl(in->sin_addr.s_addr) >> 24) == 127;
	} else {
		const struct sockaddr_in6 *in6 = (const struct sockaddr_in6 *)&a;
		*port_out = ntohs(in6->sin6_port);
		*loopback = IN6_IS_ADDR_LOOPBACK(&in6->sin6_addr);
	}
	freeaddrinfo(ai);
	return fd;
}

/* ---- the token ---- */

static void new_token(char *out, size_t cap)
{
	unsigned char raw[16];
	if (getrandom(raw, sizeof(raw), 0) != (ssize_t)sizeof(raw))
		fail(1, "cannot make a token: %s", strerror(errno));
	for (size_t i = 0; i < sizeof(raw) && 2 * i + 2 < cap; i++)
		snprintf(out + 2 * i, 3, "%02x", raw[i]);
}

/* The token, and whether to print it (only one made up here and kept
 * nowhere else). */
static bool load_token(const char *file, char *token, size_t cap)
{
	const char *env = getenv(TOKEN_ENV);
	if (!file && env && *env) {
		snprintf(token, cap, "%s", env);
		return false;
	}
	if (!file) {
		new_token(token, cap);
		return true;
	}
	FILE *f = fopen(file, "r");
	if (!f && errno == ENOENT) {
		new_token(token, cap);
		int fd = open(file, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
		if (fd < 0 || dprintf(fd, "%s\n", token) < 0 || close(fd) != 0)
			fail(1, "--token-file %s: cannot create: %s", file, strerror(errno));
		return false;
	}
	if (!f)
		fail(1, "--token-file %s: %s", file, strerror(errno));
	if (!fgets(token, (int)cap, f))
		token[0] = 0;
	fclose(f);
	token[strcspn(token, "\r\n")] = 0;
	if (strlen(token) < 8)
		fail(2, "--token-file %s: the first line must hold a token of at least 8 characters", file);
	return false;
}

/* ---- state changes: one short connection per request ---- */

typedef struct {
	const char *socket;
	atomic_int status_now;
} control_ctx;

static int control(void *ctx, mocap_command cmd, const char *argument, char *msg, size_t cap)
{
	control_ctx *cc = ctx;
	mocap_client *c = mocap_connect(cc->socket, "mocap-preview control");
	if (!c) {
		snprintf(msg, cap, "%s", mocap_errmsg());
		return mocap_errcode();
	}
	int rc = mocap_control(c, cmd, argument, msg, cap);
	if (rc < 0 && !msg[0])
		snprintf(msg, cap, "%s", mocap_errmsg());
	mocap_close(c);
	atomic_store(&cc->status_now, 1);
	return rc;
}

static void load_model(const options *o, mc_model *model, const mc_model **out)
{
	mc_err err = {""};
	*out = NULL;
	if (mc_model_load(o->model, model, &err) == 0)
		*out = model;
	else if (o->model_given)
		fail(2, "--model: %s", err.msg);
	else if (o->verbose)
		fprintf(stderr, "mocap-preview: no body model (%s): the skeleton is drawn without the Gaussians\n", err.msg);
}

/* Run from a build tree (<src>/<build>/bin/mocap-preview) before `make
 * install`: the source tree's `rel` when it is there, else NULL. */
static const char *from_source_tree(const char *rel, char *buf, size_t cap)
{
	char exe[PATH_MAX];
	if (!realpath("/proc/self/exe", exe))
		return NULL;
	for (int up = 0; up < 3; up++) { /* mocap-preview, bin, <build> */
		char *slash = strrchr(exe, '/');
		if (!slash)
			return NULL;
		*slash = 0;
	}
	char marker[PATH_MAX + 32];
	snprintf(marker, sizeof(marker), "%s/preview/mocap-preview.c", exe);
	if (access(marker, R_OK) != 0 || (size_t)snprintf(buf, cap, "%s/%s", exe, rel) >= cap)
		return NULL;
	return access(buf, R_OK) == 0 ? buf : NULL;
}

/* The installed page and model, or the source tree's when this program
 * runs from its build tree and nothing is installed. */
static void tree_defaults(options *o)
{
	static char www[PATH_MAX], model[PATH_MAX];
	if (strcmp(o->www, DEFAULT_WWW) == 0 && access(DEFAULT_WWW "/index.html", R_OK) != 0 &&
	    from_source_tree("preview/www/index.html", www, sizeof(www))) {
		*strrchr(www, '/') = 0;
		o->www = www;
	}
	if (strcmp(o->model, DEFAULT_MODEL) == 0 && access(DEFAULT_MODEL, R_OK) != 0 &&
	    from_source_tree("config/models/default.json", model, sizeof(model)))
		o->model = model;
}

int main(int argc, char **argv)
{
	options o = {.listen = DEFAULT_LISTEN, .www = DEFAULT_WWW, .three = DEFAULT_THREE, .model = DEFAULT_MODEL,
		     .rate = 10, .width = 480, .quality = 75, .verbose = true};
	parse_options(argc, argv, &o);
	tree_defaults(&o);
	setvbuf(stdout, NULL, _IOLBF, 0);
	/* The preview yields the CPU to the daemon: where both want it, the
	 * tracking goes first (nice 10; threads made later inherit it). */
	if (setpriority(PRIO_PROCESS, 0, PREVIEW_NICE) != 0 && o.verbose)
		fprintf(stderr, "mocap-preview: cannot lower its priority: %s\n", strerror(errno));
	int port = 0;
	bool loopback = false;
	int fd = listen_on(o.listen, &port, &loopback);
	char index[4200];
	snprintf(index, sizeof(index), "%s/index.html", o.www);
	if (access(index, R_OK) != 0)
		fail(2, "--www %s: no index.html there (the page's files: installed in %s, in the source tree "
			"preview/www)", o.www, DEFAULT_WWW);
	static mc_model model; /* large: not on the stack */
	const mc_model *use_model;
	load_model(&o, &model, &use_model);
	char token[256];
	bool show_token = load_token(o.token_file, token, sizeof(token));

	struct sigaction sa = {.sa_handler = on_signal};
	sigemptyset(&sa.sa_mask);
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);
	signal(SIGPIPE, SIG_IGN);

	preview_hub *hub = hub_new(o.verbose);
	control_ctx cc = {.socket = o.socket};
	http_config hc = {.www_dir = o.www, .three_dir = o.three, .token = token, .loopback = loopback, .port = port,
			  .hub = hub, .control = control, .control_ctx = &cc};
	mc_err err = {""};
	preview_http *http = hub ? http_start(fd, &hc, &err) : NULL;
	if (!http)
		fail(1, "%s", hub ? err.msg : "out of memory");
	char host[256], p[16];
	split_listen(o.listen, host, sizeof(host), p, sizeof(p));
	const char *bracket = strchr(host, ':') ? "[" : "";
	printf("mocap-preview: serving http://%s%s%s:%d/\n", bracket, host, *bracket ? "]" : "", port);
	if (show_token)
		printf("mocap-preview: to control recording, open http://%s%s%s:%d/?token=%s\n", bracket, host,
		       *bracket ? "]" : "", port, token);

	/* The thread that draws and encodes the camera views runs at nice 19:
	 * a tracker on OpenCL waits for the slowest of its worker threads, so
	 * work that preempts one of them costs the tracking several times its
	 * own CPU time.  (SCHED_IDLE starved it whenever anything else kept
	 * the CPUs busy: the page froze.)  The HTTP threads, made above, stay
	 * at nice 10.  On Linux a nice value is per thread. */
	if (setpriority(PRIO_PROCESS, (id_t)gettid(), RENDER_NICE) != 0 && o.verbose)
		fprintf(stderr, "mocap-preview: cannot lower its renderer's priority: %s\n", strerror(errno));
	link_config lc = {.socket = o.socket, .model = use_model, .rate = o.rate, .width = o.width,
			  .quality = o.quality, .verbose = o.verbose, .hub = hub, .stop = &stop,
			  .status_now = &cc.status_now};
	link_run(&lc);

	hub_stop(hub);
	http_stop(http);
	hub_free(hub);
	if (o.verbose)
		printf("mocap-preview: stopped\n");
	return 0;
}
