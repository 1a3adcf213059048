/* mocap-preview over HTTP, without a browser: mocap-preview started before
 * mocapd waits for it and says so; with mocapd on the bundled clip the
 * event stream carries the status, the skeleton and both cameras' views
 * as JPEG with the overlay drawn in (its colours are counted in the
 * decoded image); the page's files reference no other host; malformed
 * requests get 400, a foreign Host 403; a state change without the token
 * or with a wrong one gets 403 and starts no recording, with the token it
 * records a take and stops it; after mocapd restarts the views come
 * back; SIGTERM ends it cleanly.  Bad options get exit 2 and a message. */
#include "preview_fixture.h"

#include "image/mc_draw.h"
#include "image/mc_image.h"
#include "mocap.h"
#include "preview_render.h"

#include <jansson.h>

static int count(const char *hay, const char *needle)
{
	return mcd_count(hay, needle);
}

static char *sse(int port, int ms)
{
	char req[256], *resp;
	snprintf(req, sizeof(req), "GET /events HTTP/1.1\r\nHost: 127.0.0.1:%d\r\nAccept: text/event-stream\r\n\r\n", port);
	pv_raw(port, req, ms, &resp);
	return resp;
}

/* Reads the stream until needle shows (or timeout_ms passes). */
static bool sse_wait_for(int port, const char *needle, int timeout_ms)
{
	uint64_t end = mcd_now_ms() + (uint64_t)timeout_ms;
	while (mcd_now_ms() < end) {
		char *s = sse(port, 1500);
		bool found = strstr(s, needle) != NULL;
		free(s);
		if (found)
			return true;
	}
	return false;
}

static void test_usage(void)
{
	static const struct {
		const char *args[6];
		const char *says;
	} cases[] = {
		{{"--listen", "127.0.0.1"}, "--listen 127.0.0.1: expected HOST:PORT"},
		{{"--listen", "127.0.0.1:99999"}, "expected HOST:PORT"},
		{{"--listen", "no.such.host.invalid:80"}, "--listen no.such.host.invalid:80:"},
		{{"--rate", "0"}, "--rate 0: expected a number from 0.1 to 60"},
		{{"--www", "/nonexistent"}, "--www /nonexistent: no index.html there"},
		{{"--www", "preview/www", "--model", "/nonexistent.json"}, "--model: "},
		{{"stray"}, "unexpected argument 'stray'"},
	};
	char out[] = "/tmp/test-preview-usage.txt";
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		int rc = mcd_wait_pid(mcd_spawn(pv_bin, cases[i].args, out), 10000);
		char *log = mcd_read_file(out);
		CHECK_MSG(rc == 2 && log && strstr(log, cases[i].says), "case %zu: exit %d: %s", i, rc, log ? log : "");
		free(log);
	}
	unlink(out);
}

/* The first frame event of a stream: its JPEG decodes to the camera's
 * shown size, and the skeleton (red left, blue right) and the Gaussians'
 * outlines (cyan) are drawn in. */
static void check_frame_event(const char *stream)
{
	const char *ev = strstr(stream, "event: frame\ndata: ");
	CHECK_MSG(ev, "no frame event");
	if (!ev)
		return;
	ev += strlen("event: frame\ndata: ");
	json_error_t jerr;
	json_t *o = json_loadb(ev, strcspn(ev, "\n"), 0, &jerr);
	CHECK_MSG(o, "frame event: %s", jerr.text);
	const char *b64 = json_string_value(json_object_get(o, "jpeg"));
	size_t n = 0;
	uint8_t *jpeg = b64 ? pv_base64_decode(b64, strlen(b64), &n) : NULL;
	mc_err err = {""};
	mc_image_conv *conv = mc_image_conv_new(&err);
	uint8_t *rgb = NULL;
	int w = 0, h = 0;
	CHECK_MSG(jpeg && conv && mc_image_decode(conv, jpeg, n, "frame event", &rgb, &w, &h, &err) == 0, "%s", err.msg);
	CHECK_MSG(w == json_integer_value(json_object_get(o, "width")) && w == 256 && h == 256, "frame %dx%d", w, h);
	if (rgb) {
		int left = pv_count_colour(rgb, w, h, MC_DRAW_LEFT, 50), right = pv_count_colour(rgb, w, h, MC_DRAW_RIGHT, 50),
		    gauss = pv_count_colour(rgb, w, h, PREVIEW_GAUSS_COLOR, 50);
		printf("camera view %s: %dx%d, %zu bytes of JPEG; pixels in the left side's colour %d, the right's %d, "
		       "the Gaussians' outline colour %d\n",
		       json_string_value(json_object_get(o, "name")), w, h, n, left, right, gauss);
		CHECK_MSG(left >= 10 && right >= 10 && gauss >= 10, "overlay colours: left %d right %d gauss %d", left,
			  right, gauss);
	}
	free(rgb);
	free(jpeg);
	mc_image_conv_free(conv);
	json_decref(o);
}

static void check_skeleton_event(const char *stream)
{
	const char *ev = strstr(stream, "event: skeleton\ndata: ");
	CHECK_MSG(ev, "no skeleton event");
	if (!ev)
		return;
	ev += strlen("event: skeleton\ndata: ");
	json_t *o = json_loadb(ev, strcspn(ev, "\n"), 0, NULL);
	json_t *joints = json_object_get(o, "joints");
	CHECK_MSG(json_array_size(joints) >= 15, "skeleton event with %zu joints", json_array_size(joints));
	bool wrist = false;
	for (size_t i = 0; i < json_array_size(joints); i++) {
		json_t *j = json_array_get(joints, i);
		wrist |= !strcmp(json_string_value(json_object_get(j, "name")) ?: "", "left_wrist");
		double c = json_number_value(json_object_get(j, "c"));
		CHECK_MSG(c >= 0 && c <= 1, "joint %zu: confidence %g", i, c);
	}
	CHECK(wrist);
	json_decref(o);
}

/* No URL to another host in the page's own files. */
static void check_page_files(int port)
{
	static const char *const paths[] = {"/", "/preview.js", "/preview.css"};
	for (size_t i = 0; i < sizeof(paths) / sizeof(paths[0]); i++) {
		char *resp;
		int st = pv_http(port, "GET", paths[i], "", &resp);
		CHECK_MSG(st == 200 && strlen(pv_body(resp)) > 100, "GET %s: %d", paths[i], st);
		CHECK_MSG(!strstr(pv_body(resp), "http://") && !strstr(pv_body(resp), "https://") &&
				  !strstr(pv_body(resp), "src=\"//") && !strstr(pv_body(resp), "href=\"//"),
			  "%s refers to another host", paths[i]);
		CHECK_MSG(strstr(resp, "Content-Security-Policy: default-src 'self'"), "%s: no CSP", paths[i]);
		free(resp);
	}
	char *resp;
	int st = pv_http(port, "GET", "/three/three.min.js", "", &resp);
	CHECK_MSG(st == 200 || st == 404, "three.js: %d", st);
	if (st == 404)
		printf("note: three.js is not installed here (libjs-three)\n");
	free(resp);
}

static void check_malformed(int port)
{
	char *resp;
	static const char *const bad[] = {
		"BLAH BLAH\r\n\r\n",
		"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nno colon here\r\n\r\n",
		"POST /api/reload HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: abc\r\n\r\n",
		"POST /api/reload HTTP/1.1\r\nHost: 127.0.0.1\r\nTransfer-Encoding: chunked\r\n\r\nzz\r\n",
	};
	for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
		CHECK_MSG(pv_raw(port, bad[i], 5000, &resp) == 400, "malformed request %zu: %.80s", i, resp);
		free(resp);
	}
	CHECK_MSG(pv_raw(port, "GET / HTTP/1.1\r\n\r\n", 5000, &resp) == 400, "no Host: %.80s", resp);
	free(resp);
	CHECK_MSG(pv_raw(port, "GET / HTTP/1.1\r\nHost: evil.example\r\nConnection: close\r\n\r\n", 5000, &resp) == 403,
		  "foreign Host: %.80s", resp);
	free(resp);
	/* the port is the whole rest of the Host header (it was read with
	 * atoi, so that 127.0.0.1:PORTevil passed) */
	char req[160];
	snprintf(req, sizeof(req), "GET / HTTP/1.1\r\nHost: 127.0.0.1:%devil\r\nConnection: close\r\n\r\n", port);
	CHECK_MSG(pv_raw(port, req, 5000, &resp) == 403, "Host 127.0.0.1:%devil: %.80s", port, resp);
	free(resp);
	snprintf(req, sizeof(req), "GET / HTTP/1.1\r\nHost: localhost:0%d\r\nConnection: close\r\n\r\n", port);
	CHECK_MSG(pv_raw(port, req, 5000, &resp) == 403, "Host localhost:0%d: %.80s", port, resp);
	free(resp);
	snprintf(req, sizeof(req), "GET / HTTP/1.1\r\nHost: 127.0.0.1:%d\r\nConnection: close\r\n\r\n", port);
	CHECK_MSG(pv_raw(port, req, 5000, &resp) == 200, "Host 127.0.0.1:%d: %.80s", port, resp);
	free(resp);
	CHECK_MSG(pv_http(port, "GET", "/nope", "", &resp) == 404, "unknown path: %.80s", resp);
	free(resp);
	CHECK_MSG(pv_http(port, "GET", "/api/record/start", "", &resp) == 405, "GET a control: %.80s", resp);
	free(resp);
	CHECK_MSG(pv_http(port, "GET", "/../../etc/passwd", "", &resp) >= 400, "path escape: %.80s", resp);
	free(resp);
}

/* State changes need the token. */
static void check_token(const pv_run *p, const mcd_run *r)
{
	char *resp, hdr[256];
	CHECK_MSG(pv_http(p->port, "POST", "/api/record/start?name=no-token", "", &resp) == 403, "%.120s", resp);
	free(resp);
	CHECK_MSG(pv_http(p->port, "POST", "/api/record/start?name=wrong-token", "X-Mocap-Token: 0123456789abcdef\r\n",
			  &resp) == 403,
		  "%.120s", resp);
	free(resp);
	snprintf(hdr, sizeof(hdr), "X-Mocap-Token: %.*sx\r\n", (int)strlen(p->token) - 1, p->token); /* one char off */
	CHECK_MSG(pv_http(p->port, "POST", "/api/reload", hdr, &resp) == 403, "%.120s", resp);
	free(resp);
	mcd_sleep_ms(300);
	CHECK_MSG(pv_recording(r->sock) == 0, "a request without the token started a recording");
	char dir[256];
	snprintf(dir, sizeof(dir), "%s/takes/no-token", r->dir);
	CHECK(access(dir, F_OK) != 0);

	snprintf(hdr, sizeof(hdr), "X-Mocap-Token: %s\r\n", p->token);
	CHECK_MSG(pv_http(p->port, "POST", "/api/record/start?name=../escape", hdr, &resp) == 400, "%.120s", resp);
	free(resp);
	int st = pv_http(p->port, "POST", "/api/record/start?name=pv-take", hdr, &resp);
	CHECK_MSG(st == 200 && strstr(pv_body(resp), "\"ok\":true"), "record start: %d %s", st, pv_body(resp));
	free(resp);
	CHECK_MSG(pv_recording_becomes(r->sock, 1, 5000), "record start with the token: not recording");
	CHECK_MSG(sse_wait_for(p->port, "\"recording\":true", 5000), "the page is not told about the recording");
	mcd_sleep_ms(500);
	st = pv_http(p->port, "POST", "/api/record/stop", hdr, &resp);
	CHECK_MSG(st == 200, "record stop: %d %s", st, pv_body(resp));
	free(resp);
	CHECK_MSG(pv_recording_becomes(r->sock, 0, 5000), "record stop with the token: still recording");
	snprintf(dir, sizeof(dir), "%s/takes/pv-take/take.json", r->dir);
	CHECK_MSG(access(dir, R_OK) == 0, "no %s", dir);
	/* Stopping again is the daemon's refusal, passed on. */
	st = pv_http(p->port, "POST", "/api/record/stop", hdr, &resp);
	CHECK_MSG(st == 409 && strstr(pv_body(resp), "\"ok\":false"), "second stop: %d %s", st, pv_body(resp));
	free(resp);
}

static void test_with_daemon(void)
{
	mcd_run r;
	CHECK(mcd_run_init(&r));
	pv_run p;
	if (!pv_start(&p, r.dir, r.sock, NULL))
		return;
	/* 1. No daemon yet: it says so, serves the page, and waits. */
	char *s = sse(p.port, 1500);
	CHECK_MSG(strstr(s, "\"connected\":false"), "no daemon: %.200s", s);
	free(s);
	char *log = mcd_read_file(p.out);
	CHECK_MSG(strstr(log, "waiting for mocapd"), "no word about the missing daemon: %s", log);
	free(log);
	check_page_files(p.port);
	check_malformed(p.port);

	/* 2. The daemon comes: status, skeletons and camera views stream. */
	if (!pv_daemon(&r, 15)) {
		pv_stop(&p);
		return;
	}
	CHECK_MSG(sse_wait_for(p.port, "event: frame", 20000), "no camera views after the daemon started");
	s = sse(p.port, 2500);
	int nstatus = count(s, "event: status"), nskel = count(s, "event: skeleton"), nframe = count(s, "event: frame");
	printf("2.5 s of events: %d status, %d skeleton, %d frame\n", nstatus, nskel, nframe);
	/* Lenient: a busy machine tracks slower, and views follow the tracker. */
	CHECK_MSG(nstatus >= 2 && nskel >= 3 && nframe >= 4, "events: %d status, %d skeleton, %d frame", nstatus, nskel,
		  nframe);
	CHECK(strstr(s, "\"connected\":true") && strstr(s, "\"can_record\":true") && strstr(s, "\"track_ms_mean\""));
	check_frame_event(s);
	check_skeleton_event(s);
	free(s);
	check_token(&p, &r);

	/* 3. The daemon restarts: the preview notices, and the views return. */
	mcd_run_signal(&r, SIGTERM);
	CHECK(mcd_run_wait_exit(&r, 20000) == 0);
	CHECK_MSG(sse_wait_for(p.port, "\"connected\":false", 8000), "the daemon's end is not shown");
	const char *const args[] = {NULL};
	if (mcd_run_start_ready(&r, args))
		CHECK_MSG(sse_wait_for(p.port, "event: frame", 20000), "no camera views after the daemon restarted");
	log = mcd_read_file(p.out);
	CHECK_MSG(strstr(log, "lost mocapd") && count(log, "connected to mocapd") >= 2, "log: %s", log);
	free(log);
	CHECK_MSG(pv_stop(&p) == 0, "mocap-preview did not end cleanly on SIGTERM");
	if (mc_test_failures) {
		log = mcd_read_file(p.out);
		fprintf(stderr, "---- mocap-preview output ----\n%s---- end ----\n", log);
		free(log);
		mcd_run_dump(&r, "test_preview");
	}
	char cmd[320];
	snprintf(cmd, sizeof(cmd), "rm -rf %s/takes %s/preview.txt %s/preview.token", r.dir, r.dir, r.dir);
	CHECK(system(cmd) == 0);
	mcd_run_cleanup(&r);
}

int main(void)
{
	pv_setup();
	test_usage();
	test_with_daemon();
	return mc_test_finish("test_preview");
}
