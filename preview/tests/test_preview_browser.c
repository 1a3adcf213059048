/* mocap-preview in a real browser: headless Chromium (Debian's chromium),
 * driven through the DevTools protocol, loads the page from mocap-preview
 * while mocapd tracks the bundled clip.  Checked on its screenshots: both
 * camera views are there, not blank, with the overlay's colours (the
 * skeleton's sides, the Gaussians' outlines) in them; the 3D view has the
 * skeleton drawn; two screenshots a second apart differ in the camera
 * views (it is live).  The page needs no network: every request it makes
 * goes to mocap-preview's own origin, and Chromium runs with a proxy that
 * leads nowhere, so anything else would fail.  With the token in its
 * address the page's Record and Stop buttons start and stop a take.  The
 * page throws no exception and logs no error (nor a Content-Security-Policy
 * violation).
 *
 * MOCAP_PREVIEW_SHOT=FILE keeps the first screenshot (docs/images). */
#include "cdp.h"
#include "preview_fixture.h"

#include "image/mc_draw.h"
#include "image/mc_image.h"
#include "mocap.h"
#include "preview_render.h"

static const char *find_chromium(void)
{
	const char *env = getenv("CHROMIUM");
	static const char *const paths[] = {"/usr/bin/chromium", "/usr/bin/chromium-browser"};
	if (env && access(env, X_OK) == 0)
		return env;
	for (size_t i = 0; i < sizeof(paths) / sizeof(paths[0]); i++)
		if (access(paths[i], X_OK) == 0)
			return paths[i];
	return NULL;
}

typedef struct {
	uint8_t *rgb;
	int w, h;
} shot;

static bool screenshot(cdp *c, const char *session, shot *s, const char *keep)
{
	json_t *res = cdp_call(c, session, "Page.captureScreenshot", json_pack("{s:s}", "format", "png"), 30000);
	const char *data = json_string_value(json_object_get(res, "data"));
	size_t n = 0;
	uint8_t *png = data ? pv_base64_decode(data, strlen(data), &n) : NULL;
	mc_err err = {""};
	mc_image_conv *conv = mc_image_conv_new(&err);
	bool ok = png && conv && mc_image_decode(conv, png, n, "screenshot", &s->rgb, &s->w, &s->h, &err) == 0;
	CHECK_MSG(ok, "screenshot: %s", err.msg[0] ? err.msg : "none");
	if (ok && keep) {
		FILE *f = fopen(keep, "wb");
		if (f) {
			fwrite(png, 1, n, f);
			fclose(f);
		}
	}
	mc_image_conv_free(conv);
	free(png);
	json_decref(res);
	return ok;
}

typedef struct {
	int x, y, w, h;
} rect;

static rect rect_of(json_t *a, const shot *s)
{
	rect r = {(int)json_number_value(json_array_get(a, 0)), (int)json_number_value(json_array_get(a, 1)),
		  (int)json_number_value(json_array_get(a, 2)), (int)json_number_value(json_array_get(a, 3))};
	r.x = r.x < 0 ? 0 : r.x;
	r.y = r.y < 0 ? 0 : r.y;
	r.w = r.x + r.w > s->w ? s->w - r.x : r.w;
	r.h = r.y + r.h > s->h ? s->h - r.y : r.h;
	return r;
}

/* Pixels of a rectangle near colour c (tol per channel). */
static int count_in(const shot *s, rect r, const uint8_t c[3], int tol)
{
	int n = 0;
	for (int y = r.y; y < r.y + r.h; y++)
		n += pv_count_colour(s->rgb + ((size_t)y * s->w + r.x) * 3, r.w, 1, c, tol);
	return n;
}

/* Pixels of a rectangle farther than tol from c in some channel. */
static int count_not(const shot *s, rect r, const uint8_t c[3], int tol)
{
	return r.w * r.h - count_in(s, r, c, tol);
}

static double luma_stddev(const shot *s, rect r)
{
	double sum = 0, sum2 = 0;
	int n = 0;
	for (int y = r.y; y < r.y + r.h; y++)
		for (int x = r.x; x < r.x + r.w; x++) {
			const uint8_t *p = s->rgb + ((size_t)y * s->w + x) * 3;
			double l = 0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2];
			sum += l, sum2 += l * l, n++;
		}
	return n ? sqrt(fmax(0, sum2 / n - (sum / n) * (sum / n))) : 0;
}

/* Fraction of a rectangle's pixels that changed by more than 20 in some channel. */
static double changed(const shot *a, const shot *b, rect r)
{
	if (a->w != b->w || a->h != b->h || r.w <= 0 || r.h <= 0)
		return 0;
	int n = 0;
	for (int y = r.y; y < r.y + r.h; y++)
		for (int x = r.x; x < r.x + r.w; x++) {
			const uint8_t *p = a->rgb + ((size_t)y * a->w + x) * 3, *q = b->rgb + ((size_t)y * b->w + x) * 3;
			n += abs(p[0] - q[0]) > 20 || abs(p[1] - q[1]) > 20 || abs(p[2] - q[2]) > 20;
		}
	return (double)n / (r.w * r.h);
}

static const char layout_js[] =
	"(() => { const r = (e) => { if (!e) return null; const b = e.getBoundingClientRect();"
	" return [b.left, b.top, b.width, b.height]; };"
	" const imgs = [...document.querySelectorAll('.cam img')].filter((i) => i.complete && i.naturalWidth > 0);"
	" return { cams: imgs.map(r), view: document.body.dataset.view || '', canvas: r(document.querySelector('#view3d canvas')),"
	" joints: document.querySelectorAll('.joint').length, conn: document.getElementById('conn').textContent,"
	" record: !document.getElementById('recstart').hidden }; })()";

/* Waits for both camera views, the joints and the connection. */
static json_t *wait_for_page(cdp *c, const char *session)
{
	uint64_t end = mcd_now_ms() + 40000;
	json_t *v = NULL;
	while (mcd_now_ms() < end) {
		json_decref(v);
		v = cdp_eval(c, session, layout_js);
		if (json_array_size(json_object_get(v, "cams")) >= 2 && json_integer_value(json_object_get(v, "joints")) >= 15 &&
		    !strcmp(json_string_value(json_object_get(v, "conn")) ?: "", "connected"))
			return v;
		mcd_sleep_ms(250);
	}
	char *s = v ? json_dumps(v, JSON_COMPACT) : NULL;
	CHECK_MSG(false, "the page did not show the cameras and the skeleton: %s", s ? s : "(no answer)");
	free(s);
	json_decref(v);
	return NULL;
}

static void check_shots(json_t *layout, const shot *a, const shot *b)
{
	static const uint8_t bg3d[3] = {14, 16, 20}, bone[3] = {255, 230, 64};
	int left = 0, right = 0, gauss = 0;
	double least_change = 1;
	json_t *cams = json_object_get(layout, "cams");
	for (size_t i = 0; i < json_array_size(cams); i++) {
		rect r = rect_of(json_array_get(cams, i), a);
		double sd = luma_stddev(a, r);
		CHECK_MSG(r.w >= 100 && r.h >= 100 && sd > 10, "camera view %zu: %dx%d at (%d, %d), brightness stddev %.1f", i,
			  r.w, r.h, r.x, r.y, sd);
		left += count_in(a, r, MC_DRAW_LEFT, 50);
		right += count_in(a, r, MC_DRAW_RIGHT, 50);
		gauss += count_in(a, r, PREVIEW_GAUSS_COLOR, 50);
		double ch = changed(a, b, r);
		least_change = ch < least_change ? ch : least_change;
		printf("camera view %zu: %dx%d at (%d, %d), brightness stddev %.1f, %.1f%% of it changed a second later\n", i,
		       r.w, r.h, r.x, r.y, sd, 100 * ch);
	}
	printf("overlay pixels in the camera views: left side %d, right side %d, Gaussians' outlines %d\n", left, right,
	       gauss);
	CHECK_MSG(left >= 20 && right >= 20 && gauss >= 20, "overlay colours: left %d right %d gauss %d", left, right,
		  gauss);
	CHECK_MSG(least_change > 0.01, "the camera views did not change in a second (%.2f%%)", 100 * least_change);
	rect v = rect_of(json_object_get(layout, "canvas"), a);
	int drawn = count_not(a, v, bg3d, 30), bones = count_in(a, v, bone, 60);
	printf("3D view (%s): %dx%d, %d pixels off the background, %d in the bones' colour\n",
	       json_string_value(json_object_get(layout, "view")), v.w, v.h, drawn, bones);
	CHECK_MSG(v.w >= 200 && v.h >= 200 && drawn >= 300 && bones >= 30, "3D view %dx%d: %d drawn, %d bone pixels", v.w,
		  v.h, drawn, bones);
}

/* Every request went to the preview's origin (or was a data: URL). */
static void check_requests(const cdp *c, int port)
{
	char origin[64];
	snprintf(origin, sizeof(origin), "http://127.0.0.1:%d/", port);
	int own = 0;
	for (size_t i = 0; i < json_array_size(c->urls); i++) {
		const char *u = json_string_value(json_array_get(c->urls, i));
		bool ok = !strncmp(u, origin, strlen(origin)) || !strncmp(u, "data:", 5) || !strcmp(u, "about:blank");
		own += ok;
		CHECK_MSG(ok, "the page fetched %s", u);
	}
	printf("the page made %zu requests, all to %s\n", json_array_size(c->urls), origin);
	CHECK(own >= 5); /* the page, its script and style, three.js, the controls, the events */
}

/* The page's own buttons, with the token it was opened with. */
static void check_buttons(cdp *c, const char *session, json_t *layout, const char *sock)
{
	CHECK_MSG(json_is_true(json_object_get(layout, "record")), "the Record button is hidden");
	json_decref(cdp_eval(c, session, "document.getElementById('takename').value = 'from-the-page';"
					 " document.getElementById('recstart').click(); true"));
	CHECK_MSG(pv_recording_becomes(sock, 1, 10000), "the Record button did not start a take");
	mcd_sleep_ms(1500); /* the page hears of it, enables Stop */
	json_decref(cdp_eval(c, session, "document.getElementById('recstop').click(); true"));
	CHECK_MSG(pv_recording_becomes(sock, 0, 10000), "the Stop button did not stop the take");
}

int main(void)
{
	pv_setup();
	const char *chromium = find_chromium();
	if (!chromium)
		TEST_SKIP("chromium is not installed (apt-get install chromium)");
	mcd_run r;
	CHECK(mcd_run_init(&r));
	if (!pv_daemon(&r, 15))
		return mc_test_finish("test_preview_browser");
	pv_run p;
	if (!pv_start(&p, r.dir, r.sock, NULL)) {
		mcd_run_cleanup(&r);
		return mc_test_finish("test_preview_browser");
	}
	char profile[192], log[192], user_dir[224];
	snprintf(profile, sizeof(profile), "%s/chromium", r.dir);
	snprintf(log, sizeof(log), "%s/chromium.txt", r.dir);
	snprintf(user_dir, sizeof(user_dir), "--user-data-dir=%s", profile);
	/* The proxy leads nowhere (port 9, discard, nothing listens): a fetch
	 * from any host but the loopback (which bypasses proxies) fails. */
	const char *const args[] = {"--headless=new", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader",
				    "--remote-debugging-pipe", user_dir, "--no-first-run", "--no-default-browser-check",
				    "--disable-extensions", "--disable-background-networking", "--disable-component-update",
				    "--disable-sync", "--proxy-server=http://127.0.0.1:9", "--window-size=1400,900",
				    "--force-device-scale-factor=1", "--hide-scrollbars", "--mute-audio", "about:blank", NULL};
	cdp c;
	CHECK(cdp_start(&c, chromium, args, log));
	json_t *t = cdp_call(&c, NULL, "Target.createTarget", json_pack("{s:s}", "url", "about:blank"), 60000);
	json_t *a = t ? cdp_call(&c, NULL, "Target.attachToTarget",
				 json_pack("{s:O, s:b}", "targetId", json_object_get(t, "targetId"), "flatten", 1), 20000)
		      : NULL;
	const char *session = json_string_value(json_object_get(a, "sessionId"));
	CHECK_MSG(session, "cannot drive chromium (its output: %s)", log);
	json_t *layout = NULL;
	if (session) {
		json_decref(cdp_call(&c, session, "Network.enable", NULL, 20000));
		json_decref(cdp_call(&c, session, "Page.enable", NULL, 20000));
		json_decref(cdp_call(&c, session, "Runtime.enable", NULL, 20000));
		json_decref(cdp_call(&c, session, "Log.enable", NULL, 20000));
		char url[256];
		snprintf(url, sizeof(url), "http://127.0.0.1:%d/?token=%s", p.port, p.token);
		json_decref(cdp_call(&c, session, "Page.navigate", json_pack("{s:s}", "url", url), 30000));
		layout = wait_for_page(&c, session);
	}
	if (layout) {
		shot s1 = {0}, s2 = {0};
		char keep[224];
		snprintf(keep, sizeof(keep), "%s/screenshot-1.png", r.dir);
		const char *env = getenv("MOCAP_PREVIEW_SHOT");
		bool ok = screenshot(&c, session, &s1, env ? env : keep);
		mcd_sleep_ms(1000);
		ok = ok && screenshot(&c, session, &s2, NULL);
		if (ok)
			check_shots(layout, &s1, &s2);
		free(s1.rgb);
		free(s2.rgb);
		check_buttons(&c, session, layout, r.sock);
		check_requests(&c, p.port);
		char *errors = json_dumps(c.errors, JSON_COMPACT);
		CHECK_MSG(json_array_size(c.errors) == 0, "the page reported errors: %s", errors);
		free(errors);
		json_decref(layout);
	}
	json_decref(t);
	json_decref(a);
	CHECK(cdp_close(&c) == 0);
	CHECK_MSG(pv_stop(&p) == 0, "mocap-preview did not end cleanly");
	if (mc_test_failures) {
		char *l = mcd_read_file(p.out);
		fprintf(stderr, "---- mocap-preview output ----\n%s---- end ----\n", l);
		free(l);
		mcd_run_dump(&r, "test_preview_browser");
	}
	char cmd[400];
	snprintf(cmd, sizeof(cmd), "rm -rf %s/chromium %s/chromium.txt %s/takes %s/preview.* %s/screenshot-1.png", r.dir,
		 r.dir, r.dir, r.dir, r.dir);
	CHECK(system(cmd) == 0);
	mcd_run_cleanup(&r);
	return mc_test_finish("test_preview_browser");
}
