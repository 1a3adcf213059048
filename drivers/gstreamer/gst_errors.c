/* gst_errors: GStreamer's bus messages as driver statuses and messages that
 * name the config line.  See gst_internal.h. */
#include "gst_internal.h"

#include <gst/pbutils/missing-plugins.h>

#include "drv_common.h"

#include <stdio.h>
#include <string.h>

const char *gp_config_line(const gp_pipe *p, char *buf, size_t n)
{
	const char *v = p->cfg.uri ? p->cfg.uri : p->cfg.launch;
	snprintf(buf, n, "config key '%s' = '%.200s%s'", p->cfg.key, v ? v : "", v && strlen(v) > 200 ? "..." : "");
	return buf;
}

/* Errors that do not mend by waiting. */
static bool is_permanent(const GError *e, bool network)
{
	if (e->domain == GST_STREAM_ERROR)
		return e->code == GST_STREAM_ERROR_TYPE_NOT_FOUND || e->code == GST_STREAM_ERROR_CODEC_NOT_FOUND ||
		       e->code == GST_STREAM_ERROR_WRONG_TYPE || e->code == GST_STREAM_ERROR_DEMUX ||
		       e->code == GST_STREAM_ERROR_NOT_IMPLEMENTED;
	if (e->domain == GST_CORE_ERROR)
		return e->code == GST_CORE_ERROR_MISSING_PLUGIN;
	if (e->domain == GST_RESOURCE_ERROR) {
		if (e->code == GST_RESOURCE_ERROR_NOT_AUTHORIZED)
			return true; /* wrong credentials stay wrong */
		/* A file that is missing or unreadable stays so; a server may
		 * come back. */
		return !network && (e->code == GST_RESOURCE_ERROR_NOT_FOUND || e->code == GST_RESOURCE_ERROR_OPEN_READ ||
				    e->code == GST_RESOURCE_ERROR_OPEN_READ_WRITE);
	}
	return false;
}

/* The useful tail of a debug string: GStreamer puts the source position
 * and the element path first, then ":\n" and the detail. */
static void debug_tail(const char *debug, char *out, size_t n)
{
	out[0] = 0;
	if (!debug)
		return;
	const char *tail = NULL;
	for (const char *at = strstr(debug, ":\n"); at; at = strstr(at + 2, ":\n"))
		tail = at + 2;
	if (!tail && !strncmp(debug, "../", 3))
		return; /* only the source position and the element path */
	drv_strlcpy(out, tail && *tail ? tail : debug, n);
	for (char *c = out; *c; c++)
		if (*c == '\n')
			*c = ' ';
}

int gp_error_from_message(gp_pipe *p, GstMessage *msg, char *err, size_t errlen)
{
	GError *e = NULL;
	gchar *debug = NULL;
	gst_message_parse_error(msg, &e, &debug);
	char tail[256], line[300], missing[300] = "";
	debug_tail(debug, tail, sizeof tail);
	gp_config_line(p, line, sizeof line);
	g_mutex_lock(&p->lock);
	if (p->missing[0])
		snprintf(missing, sizeof missing, "; missing: %s", p->missing);
	g_mutex_unlock(&p->lock);
	int status = MDRV_ERR_IO;
	if (is_permanent(e, p->network))
		status = MDRV_ERR_CONFIG;
	else if (strstr(tail, "not-negotiated"))
		status = MDRV_ERR_FORMAT;
	else if (p->network)
		status = MDRV_ERR_NODEV;
	const char *from = GST_MESSAGE_SRC(msg) ? GST_OBJECT_NAME(GST_MESSAGE_SRC(msg)) : "?";
	drv_errf(err, errlen, status, "%s: %s: %s (%s%s%s)%s", DRV, line, e->message, from, tail[0] ? ": " : "", tail,
		 missing);
	g_error_free(e);
	g_free(debug);
	return status;
}

static void note_missing(gp_pipe *p, GstMessage *msg)
{
	gchar *desc = gst_missing_plugin_message_get_description(msg);
	g_mutex_lock(&p->lock);
	if (desc && !p->missing[0])
		drv_strlcpy(p->missing, desc, sizeof p->missing);
	g_mutex_unlock(&p->lock);
	g_free(desc);
}

int gp_poll_bus(gp_pipe *p, bool want_eos, char *err, size_t errlen)
{
	GstMessageType types = GST_MESSAGE_ERROR | GST_MESSAGE_ELEMENT | (want_eos ? GST_MESSAGE_EOS : 0);
	GstMessage *msg;
	while ((msg = gst_bus_pop_filtered(p->bus, types))) {
		int rc = MDRV_OK;
		if (GST_MESSAGE_TYPE(msg) == GST_MESSAGE_ERROR) {
			rc = gp_error_from_message(p, msg, err, errlen);
		} else if (GST_MESSAGE_TYPE(msg) == GST_MESSAGE_EOS) {
			char line[300];
			rc = drv_errf(err, errlen, MDRV_ERR_END, "%s: %s: end of stream", DRV,
				      gp_config_line(p, line, sizeof line));
		} else if (gst_is_missing_plugin_message(msg)) {
			note_missing(p, msg);
		}
		gst_message_unref(msg);
		if (rc != MDRV_OK)
			return rc;
	}
	return MDRV_OK;
}
