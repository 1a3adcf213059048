/* take_info: a take's take.json and the files copied into it
 * (docs/RECORDING.md, "The take directory"). */
#include "base/mc_file.h"
#include "take.h"

#include <jansson.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* DIR/NAME, written atomically and synced (mc_file_write_atomic). */
static int write_in(const char *dir, const char *name, const void *data, size_t n, mc_err *err)
{
	char path[4300];
	snprintf(path, sizeof(path), "%s/%s", dir, name);
	return mc_file_write_atomic(path, data, n, err);
}

int take_info_write(const char *dir, const take_info *t, mc_err *err)
{
	json_t *cams = json_array();
	for (int c = 0; c < t->ncams; c++) {
		char file[96];
		snprintf(file, sizeof(file), "cam-%s.mcr", t->cams[c]);
		json_array_append_new(cams, json_pack("{s:s, s:s, s:s, s:I, s:I}", "name", t->cams[c], "rig_camera",
						      t->rig_cams[c], "file", file, "frames", (json_int_t)t->frames[c],
						      "dropped", (json_int_t)t->frame_drops[c]));
	}
	json_t *root = json_pack("{s:s, s:i, s:s, s:I, s:I, s:I, s:b, s:s, s:I, s:I, s:I, s:o}", "format", "mocapd-take",
				 "version", 1, "name", t->name, "start_realtime_ns", (json_int_t)t->start_realtime_ns,
				 "start_monotonic_ns", (json_int_t)t->start_monotonic_ns, "stop_realtime_ns",
				 (json_int_t)t->stop_realtime_ns, "complete", t->complete, "stop_reason", t->stop_reason,
				 "poses", (json_int_t)t->poses, "pose_gaps", (json_int_t)t->pose_gaps, "bytes",
				 (json_int_t)t->bytes, "cameras", cams);
	char *text = root ? json_dumps(root, JSON_INDENT(2) | JSON_PRESERVE_ORDER) : NULL;
	json_decref(root);
	if (!text)
		return mc_err_set(err, "%s/take.json: out of memory", dir);
	size_t n = strlen(text);
	text[n] = '\n'; /* json_dumps leaves room for its NUL: replace it */
	int rc = write_in(dir, "take.json", text, n + 1, err);
	free(text);
	return rc;
}

static uint64_t get_u64(json_t *o, const char *key)
{
	json_t *v = json_object_get(o, key);
	return json_is_integer(v) && json_integer_value(v) > 0 ? (uint64_t)json_integer_value(v) : 0;
}

int take_info_read(const char *dir, take_info *t, mc_err *err)
{
	char path[4300];
	snprintf(path, sizeof(path), "%s/take.json", dir);
	json_error_t je;
	memset(t, 0, sizeof(*t));
	if (mc_file_refuse_special(path, err)) /* json_load_file would wait on a FIFO */
		return -1;
	json_t *root = json_load_file(path, 0, &je);
	if (!root && je.line < 1) /* could not open it: jansson names the file itself */
		return mc_err_set(err, "%s (not a take?)", je.text);
	if (!root)
		return mc_err_set(err, "%s: line %d: %s", path, je.line, je.text);
	const char *format = json_string_value(json_object_get(root, "format"));
	json_t *cams = json_object_get(root, "cameras");
	if (!format || strcmp(format, "mocapd-take") != 0 || !json_is_array(cams)) {
		json_decref(root);
		return mc_err_set(err, "%s: not a take (format: mocapd-take, cameras: [...])", path);
	}
	snprintf(t->name, sizeof(t->name), "%s", json_string_value(json_object_get(root, "name")) ?: "");
	t->start_realtime_ns = get_u64(root, "start_realtime_ns");
	t->start_monotonic_ns = get_u64(root, "start_monotonic_ns");
	t->stop_realtime_ns = get_u64(root, "stop_realtime_ns");
	t->complete = json_is_true(json_object_get(root, "complete"));
	snprintf(t->stop_reason, sizeof(t->stop_reason), "%s",
		 json_string_value(json_object_get(root, "stop_reason")) ?: "");
	t->poses = get_u64(root, "poses");
	t->pose_gaps = get_u64(root, "pose_gaps");
	t->bytes = get_u64(root, "bytes");
	for (size_t c = 0; c < json_array_size(cams) && c < TAKE_MAX_CAMERAS; c++) {
		json_t *cam = json_array_get(cams, c);
		snprintf(t->cams[c], sizeof(t->cams[c]), "%s", json_string_value(json_object_get(cam, "name")) ?: "");
		snprintf(t->rig_cams[c], sizeof(t->rig_cams[c]), "%s",
			 json_string_value(json_object_get(cam, "rig_camera")) ?: "");
		t->frames[c] = get_u64(cam, "frames");
		t->frame_drops[c] = get_u64(cam, "dropped");
		t->ncams++;
	}
	json_decref(root);
	return 0;
}

int take_copy_file(const char *src, const char *dir, const char *name, mc_err *err)
{
	if (!src || !src[0])
		return 0;
	uint8_t *data = NULL;
	size_t n = 0;
	if (mc_file_read(src, 64u << 20, &data, &n, err) < 0)
		return -1;
	int rc = write_in(dir, name, data, n, err);
	free(data);
	return rc;
}
