/* mocap-preview's parts without a daemon or a network: the event hub
 * (newest event per slot, in order, partial reads, keep-alive, the reader
 * count, the end at stop), base64 against RFC 4648's vectors, the token
 * comparison, the take names a page may ask for, the status JSON with and
 * without a daemon, and the history's last minute. */
#include "base/mc_time.h"
#include "preview_http.h"
#include "preview_hub.h"
#include "preview_status.h"
#include "test_util.h"

#include <jansson.h>
#include <pthread.h>

static char *read_all(hub_reader *r, size_t chunk, int keepalive_ms)
{
	static char out[4096];
	size_t len = 0;
	long n;
	char buf[64];
	/* Everything queued now: stop at the first keep-alive comment. */
	while ((n = hub_reader_read(r, buf, chunk < sizeof(buf) ? chunk : sizeof(buf), keepalive_ms)) > 0 &&
	       len + (size_t)n < sizeof(out)) {
		memcpy(out + len, buf, (size_t)n);
		len += (size_t)n;
		out[len] = 0;
		if (strstr(out, ": keep-alive"))
			break;
	}
	out[len] = 0;
	return out;
}

static void test_hub(void)
{
	preview_hub *h = hub_new(false);
	CHECK(hub_readers(h) == 0);
	hub_reader *r = hub_reader_new(h);
	CHECK(hub_readers(h) == 1);
	hub_post(h, 0, "status", "{\"a\":1}");
	hub_post(h, 2, "frame", "{\"f\":1}");
	hub_post(h, 0, "status", "{\"a\":2}"); /* replaces the first: newest wins */
	char *s = read_all(r, 5, 50);          /* small reads: events split over calls */
	CHECK_MSG(!strcmp(s, "retry: 1000\n\nevent: frame\ndata: {\"f\":1}\n\nevent: status\ndata: {\"a\":2}\n\n: keep-alive\n\n"),
		  "stream: [%s]", s);
	/* A second reader gets the newest of each slot at once. */
	hub_reader *r2 = hub_reader_new(h);
	CHECK(hub_readers(h) == 2);
	s = read_all(r2, 64, 50);
	CHECK_MSG(strstr(s, "{\"a\":2}") && strstr(s, "{\"f\":1}") && !strstr(s, "{\"a\":1}"), "second reader: [%s]", s);
	hub_reader_free(r2);
	CHECK(hub_readers(h) == 1);
	CHECK(hub_post(h, HUB_MAX_SLOTS, "x", "y") == -1);
	hub_stop(h);
	char buf[64];
	CHECK(hub_reader_read(r, buf, sizeof(buf), 1000) == -1);
	hub_reader_free(r);
	hub_free(h);
}

typedef struct {
	preview_hub *h;
	long got;
} waiter;

static void *wait_thread(void *arg)
{
	waiter *w = arg;
	hub_reader *r = hub_reader_new(w->h);
	char buf[64];
	hub_reader_read(r, buf, sizeof(buf), 5000); /* "retry" */
	w->got = hub_reader_read(r, buf, sizeof(buf), 5000);
	hub_reader_free(r);
	return NULL;
}

/* A blocked reader wakes at a post, not at its keep-alive. */
static void test_hub_wakes(void)
{
	waiter w = {.h = hub_new(false)};
	pthread_t t;
	pthread_create(&t, NULL, wait_thread, &w);
	while (hub_readers(w.h) == 0)
		usleep(1000);
	usleep(50000);
	uint64_t t0 = mc_now_ns();
	hub_post(w.h, 1, "skeleton", "{}");
	pthread_join(t, NULL);
	double ms = (double)(mc_now_ns() - t0) / 1e6;
	CHECK_MSG(w.got > 0 && ms < 1000, "woke after %.0f ms with %ld bytes", ms, w.got);
	hub_free(w.h);
}

static void test_base64(void)
{
	static const char *const in[] = {"", "f", "fo", "foo", "foob", "fooba", "foobar"};
	static const char *const out[] = {"", "Zg==", "Zm8=", "Zm9v", "Zm9vYg==", "Zm9vYmE=", "Zm9vYmFy"};
	for (int i = 0; i < 7; i++) {
		char *s = base64_encode((const uint8_t *)in[i], strlen(in[i]));
		CHECK_MSG(s && !strcmp(s, out[i]), "base64(%s) = %s", in[i], s ? s : "NULL");
		free(s);
	}
}

static void test_token_and_names(void)
{
	CHECK(http_token_ok("abcdef0123456789", "abcdef0123456789"));
	CHECK(!http_token_ok("abcdef0123456789", "abcdef012345678"));
	CHECK(!http_token_ok("abcdef0123456789", "abcdef01234567890"));
	CHECK(!http_token_ok("abcdef0123456789", "Abcdef0123456789"));
	CHECK(!http_token_ok("abcdef0123456789", ""));
	CHECK(!http_token_ok("abcdef0123456789", NULL));
	CHECK(http_take_name_ok("walk-01") && http_take_name_ok("a.b_c"));
	CHECK(!http_take_name_ok("") && !http_take_name_ok(".hidden") && !http_take_name_ok("../x") &&
	      !http_take_name_ok("/abs") && !http_take_name_ok("a b") && !http_take_name_ok("a\nb"));
	char longname[80];
	memset(longname, 'a', 65);
	longname[65] = 0;
	CHECK(!http_take_name_ok(longname));
	longname[64] = 0;
	CHECK(http_take_name_ok(longname));
}

static void test_status_json(void)
{
	static preview_history h;
	static mocap_skeleton_frame f;
	f.njoints = 2;
	f.joints[0].confidence = 1;
	f.joints[1].confidence = 0.5f;
	history_add_skeleton(&h, &f);
	history_close_second(&h, 1.0, 12.5);
	history_close_second(&h, 2.0, NAN); /* no daemon, no skeleton */
	for (int i = 0; i < HISTORY_SECONDS + 5; i++)
		history_close_second(&h, 3.0 + i, 10);
	CHECK(h.n == HISTORY_SECONDS);
	static mocap_daemon_status st;
	st.ncams = 1;
	snprintf(st.cams[0].name, sizeof(st.cams[0].name), "left \"quoted\"");
	st.cams[0].fps = 15;
	st.cams[0].drops = 3;
	st.track_ms_mean = 7.5;
	preview_status_in in = {.st = &st, .socket = "/s", .message = "m", .record_msg = "", .can_record = true, .history = &h};
	char *s = status_json(&in);
	json_t *o = json_loads(s, 0, NULL);
	CHECK_MSG(o && json_is_true(json_object_get(o, "connected")), "%s", s);
	json_t *cam = json_array_get(json_object_get(json_object_get(o, "daemon"), "cameras"), 0);
	CHECK(!strcmp(json_string_value(json_object_get(cam, "name")) ?: "", "left \"quoted\""));
	CHECK(json_integer_value(json_object_get(cam, "drops")) == 3);
	CHECK(json_array_size(json_object_get(json_object_get(o, "history"), "t")) == HISTORY_SECONDS);
	json_decref(o);
	free(s);
	/* The first points: confidence 0.75 then null (no skeleton that second). */
	static preview_history h2;
	history_add_skeleton(&h2, &f);
	history_close_second(&h2, 1.0, 12.5);
	history_close_second(&h2, 2.0, NAN);
	in = (preview_status_in){.st = NULL, .socket = "/s", .message = "waiting", .history = &h2};
	s = status_json(&in);
	o = json_loads(s, 0, NULL);
	json_t *conf = json_object_get(json_object_get(o, "history"), "confidence");
	CHECK_MSG(o && json_is_false(json_object_get(o, "connected")) && !json_object_get(o, "daemon") &&
			  fabs(json_number_value(json_array_get(conf, 0)) - 0.75) < 1e-9 && json_is_null(json_array_get(conf, 1)),
		  "%s", s);
	json_decref(o);
	free(s);
}

int main(void)
{
	test_hub();
	test_hub_wakes();
	test_base64();
	test_token_and_names();
	test_status_json();
	return mc_test_finish("test_preview_unit");
}
