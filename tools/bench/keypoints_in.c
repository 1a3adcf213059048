#include "bench/keypoints_in.h"

#include "base/mc_json.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* What reading one file needs besides its result. */
typedef struct {
	const char *path;
	int line;
	const mc_rig *rig;
	const mc_model *m;
	int cap;        /* kp's allocation */
	int *frame_of;  /* the frame set of each kp, in file order */
	bool *seen;     /* frame sets given so far */
	int rig_views;  /* views that named a rig camera */
} reader;

static int grow(reader *r, bench_keypoints_in *in, mc_err *err)
{
	if (in->nkp < r->cap)
		return 0;
	int cap = r->cap ? 2 * r->cap : 1024;
	mc_keypoint *kp = realloc(in->kp, (size_t)cap * sizeof(*kp));
	if (kp)
		in->kp = kp;
	int *frame_of = realloc(r->frame_of, (size_t)cap * sizeof(*frame_of));
	if (frame_of)
		r->frame_of = frame_of;
	if (!kp || !frame_of)
		return mc_err_set(err, "%s: out of memory", r->path);
	r->cap = cap;
	return 0;
}

/* joints.name, [u, v, confidence], of camera cam at frame set k (where:
 * the path of joints, for errors). */
static int read_joint(reader *r, bench_keypoints_in *in, int k, int cam, const json_t *joints, const char *name,
		      const char *where, mc_err *err)
{
	int joint = mc_model_find_joint(r->m, name);
	if (joint < 0)
		return mc_err_set(err, "%s:%d: joint \"%s\": the body model has no such joint", r->path, r->line, name);
	double uvc[3];
	if (mc_json_numbers(joints, name, where, uvc, 3, true, err) < 0)
		return -1;
	if (!(uvc[2] >= 0 && uvc[2] <= 1))
		return mc_err_set(err, "%s:%d: joint \"%s\": expected [u, v, confidence], confidence in [0, 1]",
				  r->path, r->line, name);
	if (grow(r, in, err) < 0)
		return -1;
	in->kp[in->nkp] = (mc_keypoint){.cam = cam, .joint = joint, .u = uvc[0], .v = uvc[1], .conf = uvc[2]};
	r->frame_of[in->nkp++] = k;
	return 0;
}

static int read_view(reader *r, bench_keypoints_in *in, int k, const json_t *view, size_t i, mc_err *err)
{
	char where[512], camera[MC_CAMERA_NAME_MAX];
	snprintf(where, sizeof(where), "%s:%d: views[%zu]", r->path, r->line, i);
	if (!json_is_object(view))
		return mc_err_set(err, "%s: expected an object", where);
	if (mc_json_string(view, "camera", where, camera, sizeof(camera), true, err) < 0)
		return -1;
	const json_t *joints = json_object_get(view, "joints");
	if (!json_is_object(joints))
		return mc_err_set(err, "%s.joints: expected an object", where);
	int cam = mc_rig_find(r->rig, camera);
	if (cam < 0)
		return 0;
	r->rig_views++;
	char joints_where[600];
	snprintf(joints_where, sizeof(joints_where), "%s.joints", where);
	const char *name;
	const json_t *value;
	json_object_foreach ((json_t *)joints, name, value)
		if (read_joint(r, in, k, cam, joints, name, joints_where, err) < 0)
			return -1;
	return 0;
}

static int read_line(reader *r, bench_keypoints_in *in, const char *text, mc_err *err)
{
	char where[512];
	snprintf(where, sizeof(where), "%s:%d", r->path, r->line);
	json_t *root;
	if (mc_json_load_text(text, where, &root, err) < 0)
		return -1;
	int k, rc = -1;
	const json_t *views = json_object_get(root, "views");
	if (!json_is_object(root))
		mc_err_set(err, "%s: expected an object", where);
	else if (mc_json_int(root, "index", where, 0, in->nframes - 1, &k, true, err) < 0)
		;
	else if (r->seen[k])
		mc_err_set(err, "%s: index %d given twice", where, k);
	else if (!json_is_array(views))
		mc_err_set(err, "%s: views: expected an array", where);
	else {
		r->seen[k] = true;
		rc = 0;
		for (size_t i = 0; i < json_array_size(views) && rc == 0; i++)
			rc = read_view(r, in, k, json_array_get(views, i), i, err);
	}
	json_decref(root);
	return rc;
}

/* Orders the keypoints by frame set (stable: a view's keep the file's
 * order) and indexes them. */
static int index_frames(reader *r, bench_keypoints_in *in, mc_err *err)
{
	mc_keypoint *sorted = malloc((size_t)(in->nkp ? in->nkp : 1) * sizeof(*sorted));
	if (!sorted)
		return mc_err_set(err, "%s: out of memory", r->path);
	for (int i = 0; i < in->nkp; i++)
		in->count[r->frame_of[i]]++;
	for (int k = 1; k < in->nframes; k++)
		in->first[k] = in->first[k - 1] + in->count[k - 1];
	int *fill = calloc((size_t)in->nframes, sizeof(*fill));
	if (!fill) {
		free(sorted);
		return mc_err_set(err, "%s: out of memory", r->path);
	}
	for (int i = 0; i < in->nkp; i++)
		sorted[in->first[r->frame_of[i]] + fill[r->frame_of[i]]++] = in->kp[i];
	free(fill);
	free(in->kp);
	in->kp = sorted;
	return 0;
}

static int read_all(reader *r, FILE *f, bench_keypoints_in *in, mc_err *err)
{
	char *text = NULL;
	size_t size = 0;
	int rc = 0;
	while (rc == 0 && getline(&text, &size, f) >= 0) {
		r->line++;
		if (strspn(text, " \t\r\n") != strlen(text))
			rc = read_line(r, in, text, err);
	}
	free(text);
	if (rc == 0 && ferror(f))
		rc = mc_err_set(err, "%s: read error", r->path);
	if (rc == 0 && r->rig_views == 0)
		rc = mc_err_set(err, "%s: no view names a camera of this rig (the first is \"%s\")", r->path,
				r->rig->cams[0].name);
	return rc == 0 ? index_frames(r, in, err) : -1;
}

int bench_keypoints_read(const char *path, const mc_rig *rig, const mc_model *m, int nframes, bench_keypoints_in *in,
			 mc_err *err)
{
	memset(in, 0, sizeof(*in));
	FILE *f = fopen(path, "r");
	if (!f)
		return mc_err_set(err, "%s: cannot read", path);
	reader r = {.path = path, .rig = rig, .m = m};
	in->nframes = nframes;
	in->first = calloc((size_t)nframes, sizeof(int));
	in->count = calloc((size_t)nframes, sizeof(int));
	r.seen = calloc((size_t)nframes, sizeof(bool));
	int rc = in->first && in->count && r.seen ? read_all(&r, f, in, err) : mc_err_set(err, "%s: out of memory", path);
	fclose(f);
	free(r.seen);
	free(r.frame_of);
	if (rc < 0)
		bench_keypoints_in_free(in);
	return rc;
}

int bench_keypoints_frame(const bench_keypoints_in *in, int k, mc_keypoint *out, int cap)
{
	if (k < 0 || k >= in->nframes)
		return 0;
	int n = in->count[k] < cap ? in->count[k] : cap;
	memcpy(out, in->kp + in->first[k], (size_t)n * sizeof(*out));
	return n;
}

void bench_keypoints_in_free(bench_keypoints_in *in)
{
	free(in->first);
	free(in->count);
	free(in->kp);
	memset(in, 0, sizeof(*in));
}
