/* gst_test_util: what the gstreamer driver's tests share: skipping (exit
 * 77) when GStreamer elements they need are really absent, making media
 * files with the GStreamer API, and recording the status a failed open()
 * reports through mdrv_host.open_status. */
#ifndef GST_TEST_UTIL_H
#define GST_TEST_UTIL_H

#include <gst/gst.h>
#include <stdio.h>
#include <stdlib.h>

#include "drv_check.h"

/* Exits 77 with the names of the elements that are not installed. */
static inline void gst_test_require(const char *const *elements, int n)
{
	GError *e = NULL;
	if (!gst_init_check(NULL, NULL, &e)) {
		printf("SKIP: GStreamer does not initialise: %s\n", e ? e->message : "?");
		exit(77);
	}
	char missing[512] = "";
	for (int i = 0; i < n; i++) {
		GstElementFactory *f = gst_element_factory_find(elements[i]);
		if (f)
			gst_object_unref(f);
		else
			snprintf(missing + strlen(missing), sizeof missing - strlen(missing), " %s", elements[i]);
	}
	if (missing[0]) {
		printf("SKIP: GStreamer elements not installed:%s (make deps)\n", missing);
		exit(77);
	}
}

/* 1 when the element is installed. */
static inline int gst_test_have(const char *element)
{
	GstElementFactory *f = gst_element_factory_find(element);
	if (f)
		gst_object_unref(f);
	return f != NULL;
}

/* Runs a gst-launch description to its end; 0, or -1 with the error
 * printed. */
static inline int gst_test_run(const char *desc)
{
	GError *e = NULL;
	GstElement *p = gst_parse_launch(desc, &e);
	if (!p) {
		fprintf(stderr, "'%s': %s\n", desc, e ? e->message : "?");
		g_clear_error(&e);
		return -1;
	}
	g_clear_error(&e);
	gst_element_set_state(p, GST_STATE_PLAYING);
	GstBus *bus = gst_element_get_bus(p);
	GstMessage *m = gst_bus_timed_pop_filtered(bus, 60 * GST_SECOND, GST_MESSAGE_EOS | GST_MESSAGE_ERROR);
	int rc = 0;
	if (!m || GST_MESSAGE_TYPE(m) == GST_MESSAGE_ERROR) {
		GError *err = NULL;
		if (m)
			gst_message_parse_error(m, &err, NULL);
		fprintf(stderr, "'%s': %s\n", desc, err ? err->message : "timed out");
		g_clear_error(&err);
		rc = -1;
	}
	if (m)
		gst_message_unref(m);
	gst_object_unref(bus);
	gst_element_set_state(p, GST_STATE_NULL);
	gst_object_unref(p);
	return rc;
}

/* The last status a failed open() passed to host->open_status. */
static int gst_test_open_status;
static inline void gst_test_record_status(void *ctx, int status)
{
	(void)ctx;
	gst_test_open_status = status;
}

/* Opens with h's config, expecting failure with `status` (through
 * open_status) and a message holding each of the needles (NULL-ended). */
static inline void gst_test_open_fails(drv_harness *h, int status, const char *const *needles)
{
	char err[1024] = "";
	h->host.open_status = gst_test_record_status;
	gst_test_open_status = 0;
	void *dev = h->drv->open(&h->host, err, sizeof err);
	CHECK_MSG(dev == NULL, "open should fail (%s)", needles[0]);
	if (dev) {
		h->drv->close(dev);
		return;
	}
	printf("  open failed as expected (status %d): %s\n", gst_test_open_status, err);
	CHECK_MSG(gst_test_open_status == status, "open status %d, expected %d (%s)", gst_test_open_status, status,
		  err);
	CHECK_MSG(strncmp(err, "gstreamer: ", 11) == 0, "'%s' should name the driver", err);
	for (int i = 0; needles[i]; i++)
		CHECK_MSG(strstr(err, needles[i]) != NULL, "'%s' should mention '%s'", err, needles[i]);
}

#endif
