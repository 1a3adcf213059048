/* gst_probe: the video sources GStreamer's device providers find (V4L2
 * cameras, PipeWire nodes, ...), for mocapd --probe.
 *
 * A GstDeviceMonitor filtered on "Video/Source" lists the devices.  Each
 * one's id is the gst-launch description of the element that captures
 * from it (gst_device_create_element: its factory and every property that
 * differs from the default, e.g. "v4l2src device=/dev/video0"), which a
 * config's `pipeline` key takes in front of the caps and the appsink; its
 * modes are its caps, in the formats the driver delivers (raw video,
 * converted to RGB24, and JPEG, passed through). */
#include "drv_common.h"
#include "gst_internal.h"
#include "gst_probe.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Properties a description must not set (the element's identity). */
static bool skipped_property(const GParamSpec *ps)
{
	return !(ps->flags & G_PARAM_READABLE) || !(ps->flags & G_PARAM_WRITABLE) ||
	       (ps->flags & G_PARAM_CONSTRUCT_ONLY) || !strcmp(ps->name, "name") || !strcmp(ps->name, "parent");
}

/* " key=value" for every property of el that differs from its default;
 * false if the description does not fit. */
static bool append_properties(GstElement *el, char *out, size_t cap)
{
	guint n = 0;
	GParamSpec **props = g_object_class_list_properties(G_OBJECT_GET_CLASS(el), &n);
	bool fits = true;
	for (guint i = 0; i < n && fits; i++) {
		if (skipped_property(props[i]))
			continue;
		GValue v = G_VALUE_INIT;
		g_value_init(&v, props[i]->value_type);
		g_object_get_property(G_OBJECT(el), props[i]->name, &v);
		gchar *s = g_param_value_defaults(props[i], &v) ? NULL : gst_value_serialize(&v);
		if (s) {
			size_t len = strlen(out);
			fits = (size_t)snprintf(out + len, cap - len, " %s=%s", props[i]->name, s) < cap - len;
		}
		g_free(s);
		g_value_unset(&v);
	}
	g_free(props);
	return fits;
}

/* The description of the element that captures from dev; false if there
 * is none or it does not fit. */
static bool device_description(GstDevice *dev, char *out, size_t cap)
{
	GstElement *el = gst_device_create_element(dev, NULL);
	if (!el)
		return false;
	GstElementFactory *f = gst_element_get_factory(el);
	bool ok = f && (size_t)snprintf(out, cap, "%s", GST_OBJECT_NAME(f)) < cap && append_properties(el, out, cap);
	gst_object_unref(el);
	return ok;
}

/* A device property as text ("" if absent), whatever its type. */
static void property_text(const GstStructure *st, const char *key, char *out, size_t cap)
{
	const GValue *v = st ? gst_structure_get_value(st, key) : NULL;
	out[0] = 0;
	if (!v)
		return;
	GValue s = G_VALUE_INIT;
	g_value_init(&s, G_TYPE_STRING);
	if (g_value_transform(v, &s) && g_value_get_string(&s))
		snprintf(out, cap, "%s", g_value_get_string(&s));
	g_value_unset(&s);
}

/* The first of the keys the device's properties have. */
static void first_property(const GstStructure *st, const char *const *keys, char *out, size_t cap)
{
	for (out[0] = 0; *keys && !out[0]; keys++)
		property_text(st, *keys, out, cap);
}

static void describe(GstDevice *dev, mdrv_device_info *info)
{
	static const char *const bus_keys[] = {"device.bus_path", "object.path", "sysfs.path", "api.v4l2.path", NULL};
	static const char *const serial_keys[] = {"device.serial", "object.serial", NULL};
	gchar *name = gst_device_get_display_name(dev);
	drv_strlcpy(info->name, name, sizeof(info->name));
	g_free(name);
	GstStructure *props = gst_device_get_properties(dev);
	first_property(props, bus_keys, info->bus_info, sizeof(info->bus_info));
	first_property(props, serial_keys, info->serial, sizeof(info->serial));
	if (props)
		gst_structure_free(props);
}

/* The devices the monitor finds now (a list to free with g_list_free_full
 * and gst_object_unref); NULL when there are none or no provider. */
static GList *video_sources(void)
{
	GstDeviceMonitor *mon = gst_device_monitor_new();
	gst_device_monitor_add_filter(mon, "Video/Source", NULL);
	GList *devs = NULL;
	/* Without a start the providers are not probed; a start fails when no
	 * provider is installed for the class, which is no device. */
	if (gst_device_monitor_start(mon)) {
		devs = gst_device_monitor_get_devices(mon);
		gst_device_monitor_stop(mon);
	}
	gst_object_unref(mon);
	return devs;
}

int gp_probe_devices(mdrv_device_info *out, int max, char *err, size_t errlen)
{
	if (gp_init(err, errlen) != MDRV_OK)
		return MDRV_ERR_IO;
	GList *devs = video_sources();
	int n = 0;
	for (GList *l = devs; l && n < max; l = l->next) {
		GstDevice *dev = GST_DEVICE(l->data);
		memset(&out[n], 0, sizeof(out[n]));
		/* A device without a description that fits cannot be pasted. */
		if (!device_description(dev, out[n].id, sizeof(out[n].id)))
			continue;
		describe(dev, &out[n++]);
	}
	g_list_free_full(devs, gst_object_unref);
	return n;
}

int gp_probe_modes(const char *id, mdrv_mode *out, int max, char *err, size_t errlen)
{
	if (gp_init(err, errlen) != MDRV_OK)
		return MDRV_ERR_IO;
	GList *devs = video_sources();
	GstCaps *caps = NULL;
	char desc[sizeof(((mdrv_device_info *)0)->id)];
	for (GList *l = devs; l && !caps; l = l->next)
		if (device_description(GST_DEVICE(l->data), desc, sizeof(desc)) && !strcmp(desc, id))
			caps = gst_device_get_caps(GST_DEVICE(l->data));
	g_list_free_full(devs, gst_object_unref);
	if (!caps)
		return drv_errf(err, errlen, MDRV_ERR_NODEV, "%s: no video source '%s' (any more)", DRV, id ? id : "");
	int n = gp_caps_modes(caps, out, max);
	gst_caps_unref(caps);
	return n;
}

/* ---- caps to modes ---- */

/* The largest value of an int field: fixed, a range or a list; 0 if none. */
static int int_max(const GstStructure *st, const char *field)
{
	const GValue *v = gst_structure_get_value(st, field);
	if (!v)
		return 0;
	if (G_VALUE_HOLDS_INT(v))
		return g_value_get_int(v);
	if (GST_VALUE_HOLDS_INT_RANGE(v))
		return gst_value_get_int_range_max(v);
	int best = 0;
	for (guint i = 0; GST_VALUE_HOLDS_LIST(v) && i < gst_value_list_get_size(v); i++) {
		const GValue *e = gst_value_list_get_value(v, i);
		if (G_VALUE_HOLDS_INT(e) && g_value_get_int(e) > best)
			best = g_value_get_int(e);
	}
	return best;
}

static double fraction(const GValue *v)
{
	int d = gst_value_get_fraction_denominator(v);
	return d > 0 ? (double)gst_value_get_fraction_numerator(v) / d : 0;
}

static void add_rate(mdrv_mode *m, double fps)
{
	if (fps <= 0 || m->nfps >= MDRV_MODE_RATES)
		return;
	uint32_t k = m->nfps++;
	while (k > 0 && m->fps[k - 1] < fps) { /* highest first */
		m->fps[k] = m->fps[k - 1];
		k--;
	}
	m->fps[k] = fps;
}

/* The rates: a fraction, a list of them, or a range. */
static void read_rates(const GstStructure *st, mdrv_mode *m)
{
	const GValue *v = gst_structure_get_value(st, "framerate");
	if (!v)
		return;
	if (GST_VALUE_HOLDS_FRACTION(v)) {
		add_rate(m, fraction(v));
	} else if (GST_VALUE_HOLDS_FRACTION_RANGE(v)) {
		m->fps_min = fraction(gst_value_get_fraction_range_min(v));
		m->fps_max = fraction(gst_value_get_fraction_range_max(v));
	} else if (GST_VALUE_HOLDS_LIST(v)) {
		for (guint i = 0; i < gst_value_list_get_size(v); i++) {
			const GValue *e = gst_value_list_get_value(v, i);
			if (GST_VALUE_HOLDS_FRACTION(e))
				add_rate(m, fraction(e));
		}
	}
}

/* The format of one caps structure as a mode's name and pixel format;
 * false for what the driver does not take (H.264, Bayer, ...), and for
 * memory that is not the system's (DMA buffers need other elements). */
static bool structure_format(const GstStructure *st, const GstCapsFeatures *feat, mdrv_mode *m)
{
	if (feat && !gst_caps_features_is_any(feat) &&
	    !gst_caps_features_contains(feat, GST_CAPS_FEATURE_MEMORY_SYSTEM_MEMORY))
		return false;
	if (gst_structure_has_name(st, "image/jpeg")) {
		drv_strlcpy(m->pixel_format, "MJPEG", sizeof(m->pixel_format));
		m->pixfmt = MC_PIXFMT_MJPEG; /* passed through, as format = auto does */
		return true;
	}
	const char *f = gst_structure_get_string(st, "format");
	if (!gst_structure_has_name(st, "video/x-raw") || !f)
		return false;
	drv_strlcpy(m->pixel_format, f, sizeof(m->pixel_format));
	m->pixfmt = MC_PIXFMT_RGB24; /* videoconvert, as format = auto does */
	return true;
}

int gp_caps_modes(const GstCaps *caps, mdrv_mode *out, int max)
{
	int n = 0;
	for (guint i = 0; caps && i < gst_caps_get_size(caps) && n < max; i++) {
		const GstStructure *st = gst_caps_get_structure(caps, i);
		mdrv_mode *m = &out[n];
		memset(m, 0, sizeof(*m));
		drv_strlcpy(m->format_key, "pipeline", sizeof(m->format_key));
		if (!structure_format(st, gst_caps_get_features(caps, i), m))
			continue;
		m->width = (uint32_t)int_max(st, "width");
		m->height = (uint32_t)int_max(st, "height");
		read_rates(st, m);
		if (m->width && m->height)
			n++;
	}
	return n;
}
