/* mc_bvh: BVH parser and forward kinematics (see mc_bvh.h). */
#include "body/mc_bvh.h"

#include "base/mc_file.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define TOKEN_MAX 128
#define MAX_DEPTH 128

typedef struct {
	const char *p, *end;
	int line;
	const char *origin;
	mc_err *err;
} lexer;

/* Reads the next token ('{', '}', or a run of other non-space characters)
 * into tok. Returns 1, 0 at the end of the text, -1 on error. */
static int next_token(lexer *lx, char tok[TOKEN_MAX])
{
	while (lx->p < lx->end && (*lx->p == ' ' || *lx->p == '\t' || *lx->p == '\r' || *lx->p == '\n')) {
		if (*lx->p == '\n')
			lx->line++;
		lx->p++;
	}
	if (lx->p >= lx->end)
		return 0;
	size_t n = 0;
	if (*lx->p == '{' || *lx->p == '}') {
		tok[n++] = *lx->p++;
	} else {
		while (lx->p < lx->end && !strchr(" \t\r\n{}", *lx->p) && *lx->p) {
			if (n + 1 >= TOKEN_MAX)
				return mc_err_set(lx->err, "%s:%d: token too long", lx->origin, lx->line);
			tok[n++] = *lx->p++;
		}
		if (n == 0)
			return mc_err_set(lx->err, "%s:%d: NUL byte in the text", lx->origin, lx->line);
	}
	tok[n] = 0;
	return 1;
}

/* Reads a token that must exist; `what` says what was expected. */
static int need_token(lexer *lx, char tok[TOKEN_MAX], const char *what)
{
	int rc = next_token(lx, tok);
	if (rc == 0)
		return mc_err_set(lx->err, "%s:%d: unexpected end of file, expected %s", lx->origin, lx->line, what);
	return rc < 0 ? -1 : 0;
}

static int parse_double(const char *s, double *v)
{
	char *end;
	errno = 0;
	*v = strtod(s, &end);
	return (end != s && *end == 0 && errno == 0 && isfinite(*v)) ? 0 : -1;
}

static int need_number(lexer *lx, const char *what, double *v)
{
	char tok[TOKEN_MAX];
	if (need_token(lx, tok, what) != 0)
		return -1;
	if (parse_double(tok, v) != 0)
		return mc_err_set(lx->err, "%s:%d: %s: '%s' is not a number", lx->origin, lx->line, what, tok);
	return 0;
}

static int channel_from_name(const char *s)
{
	static const char *const names[6] = {"Xposition", "Yposition", "Zposition",
					     "Xrotation", "Yrotation", "Zrotation"};
	for (int i = 0; i < 6; i++)
		if (strcmp(s, names[i]) == 0)
			return i;
	return -1;
}

static int add_joint(lexer *lx, mc_bvh *b, const char *name, int parent, bool end_site)
{
	if (b->njoints >= MC_BVH_MAX_JOINTS)
		return mc_err_set(lx->err, "%s:%d: more than %d joints", lx->origin, lx->line, MC_BVH_MAX_JOINTS);
	if (!b->joints) {
		b->joints = calloc(MC_BVH_MAX_JOINTS, sizeof(mc_bvh_joint));
		if (!b->joints)
			return mc_err_set(lx->err, "%s: out of memory", lx->origin);
	}
	mc_bvh_joint *j = &b->joints[b->njoints];
	memset(j, 0, sizeof(*j));
	if (end_site)
		snprintf(j->name, sizeof(j->name), "%.*s_End", MC_BVH_NAME_MAX - 5, b->joints[parent].name);
	else if (strlen(name) >= MC_BVH_NAME_MAX)
		return mc_err_set(lx->err, "%s:%d: joint name '%s' longer than %d characters", lx->origin, lx->line,
				  name, MC_BVH_NAME_MAX - 1);
	else
		snprintf(j->name, sizeof(j->name), "%s", name);
	j->parent = parent;
	j->end_site = end_site;
	j->channel0 = b->nchannels;
	return b->njoints++;
}

static int parse_channels(lexer *lx, mc_bvh *b, mc_bvh_joint *j)
{
	char tok[TOKEN_MAX];
	double n;
	if (need_number(lx, "CHANNELS count", &n) != 0)
		return -1;
	if (n != floor(n) || n < 0 || n > 6)
		return mc_err_set(lx->err, "%s:%d: CHANNELS: count %g is not 0..6", lx->origin, lx->line, n);
	if (j->nchannels)
		return mc_err_set(lx->err, "%s:%d: joint '%s' has a second CHANNELS line", lx->origin, lx->line,
				  j->name);
	j->channel0 = b->nchannels;
	for (int i = 0; i < (int)n; i++) {
		if (need_token(lx, tok, "a channel name") != 0)
			return -1;
		int c = channel_from_name(tok);
		if (c < 0)
			return mc_err_set(lx->err, "%s:%d: CHANNELS: '%s' is not a channel name", lx->origin,
					  lx->line, tok);
		j->channels[i] = (uint8_t)c;
	}
	j->nchannels = (int)n;
	b->nchannels += j->nchannels;
	return 0;
}

/* Parses "{ ... }" of the joint just added at index `ji`. */
static int parse_block(lexer *lx, mc_bvh *b, int ji, int depth)
{
	char tok[TOKEN_MAX];
	if (depth > MAX_DEPTH)
		return mc_err_set(lx->err, "%s:%d: joints nested deeper than %d", lx->origin, lx->line, MAX_DEPTH);
	if (need_token(lx, tok, "'{'") != 0)
		return -1;
	if (strcmp(tok, "{") != 0)
		return mc_err_set(lx->err, "%s:%d: expected '{' after joint '%s', got '%s'", lx->origin, lx->line,
				  b->joints[ji].name, tok);
	bool have_offset = false;
	for (;;) {
		if (need_token(lx, tok, "'}'") != 0)
			return -1;
		bool end_site = b->joints[ji].end_site;
		if (strcmp(tok, "}") == 0)
			break;
		if (strcmp(tok, "OFFSET") == 0) {
			double v[3];
			for (int i = 0; i < 3; i++)
				if (need_number(lx, "OFFSET", &v[i]) != 0)
					return -1;
			b->joints[ji].offset = mc_v3(v[0], v[1], v[2]);
			have_offset = true;
		} else if (strcmp(tok, "CHANNELS") == 0 && !end_site) {
			if (parse_channels(lx, b, &b->joints[ji]) != 0)
				return -1;
		} else if (strcmp(tok, "JOINT") == 0 && !end_site) {
			if (need_token(lx, tok, "a joint name") != 0)
				return -1;
			int child = add_joint(lx, b, tok, ji, false);
			if (child < 0 || parse_block(lx, b, child, depth + 1) != 0)
				return -1;
		} else if (strcmp(tok, "End") == 0 && !end_site) {
			if (need_token(lx, tok, "'Site'") != 0)
				return -1;
			if (strcmp(tok, "Site") != 0)
				return mc_err_set(lx->err, "%s:%d: expected 'End Site', got 'End %s'", lx->origin,
						  lx->line, tok);
			int child = add_joint(lx, b, NULL, ji, true);
			if (child < 0 || parse_block(lx, b, child, depth + 1) != 0)
				return -1;
		} else {
			return mc_err_set(lx->err, "%s:%d: unexpected '%s' in %s '%s'", lx->origin, lx->line, tok,
					  end_site ? "End Site of" : "joint",
					  b->joints[end_site ? b->joints[ji].parent : ji].name);
		}
	}
	if (!have_offset)
		return mc_err_set(lx->err, "%s:%d: joint '%s' has no OFFSET", lx->origin, lx->line, b->joints[ji].name);
	return 0;
}

static int parse_hierarchy(lexer *lx, mc_bvh *b, char tok[TOKEN_MAX])
{
	if (need_token(lx, tok, "HIERARCHY") != 0)
		return -1;
	if (strcmp(tok, "HIERARCHY") != 0)
		return mc_err_set(lx->err, "%s:%d: expected HIERARCHY, got '%s'", lx->origin, lx->line, tok);
	for (;;) {
		if (need_token(lx, tok, "ROOT or MOTION") != 0)
			return -1;
		if (strcmp(tok, "MOTION") == 0)
			break;
		if (strcmp(tok, "ROOT") != 0)
			return mc_err_set(lx->err, "%s:%d: expected ROOT or MOTION, got '%s'", lx->origin, lx->line, tok);
		if (need_token(lx, tok, "the root's name") != 0)
			return -1;
		int root = add_joint(lx, b, tok, -1, false);
		if (root < 0 || parse_block(lx, b, root, 0) != 0)
			return -1;
	}
	if (b->njoints == 0)
		return mc_err_set(lx->err, "%s:%d: HIERARCHY has no ROOT", lx->origin, lx->line);
	return 0;
}

/* Frames: N / Frame Time: T, then the value lines. */
static int parse_motion(lexer *lx, mc_bvh *b, char tok[TOKEN_MAX])
{
	double n, ft;
	if (need_token(lx, tok, "'Frames:'") != 0)
		return -1;
	if (strcmp(tok, "Frames:") != 0)
		return mc_err_set(lx->err, "%s:%d: expected 'Frames:', got '%s'", lx->origin, lx->line, tok);
	if (need_number(lx, "Frames", &n) != 0)
		return -1;
	if (n != floor(n) || n < 0 || n > 1e8)
		return mc_err_set(lx->err, "%s:%d: Frames: %g is not a frame count", lx->origin, lx->line, n);
	if (need_token(lx, tok, "'Frame Time:'") != 0)
		return -1;
	if (strcmp(tok, "Frame") != 0 || need_token(lx, tok, "'Time:'") != 0 || strcmp(tok, "Time:") != 0)
		return mc_err_set(lx->err, "%s:%d: expected 'Frame Time:'", lx->origin, lx->line);
	if (need_number(lx, "Frame Time", &ft) != 0)
		return -1;
	if (!(ft > 0 && ft < 3600))
		return mc_err_set(lx->err, "%s:%d: Frame Time: %g s is not a frame period", lx->origin, lx->line, ft);
	b->nframes = (int)n;
	b->frame_time = ft;
	/* Each value takes at least one character: a count the text cannot
	 * hold is an error before anything is allocated. */
	size_t want = (size_t)b->nframes * (size_t)b->nchannels;
	if (want > (size_t)(lx->end - lx->p) + 1)
		return mc_err_set(lx->err, "%s:%d: Frames: %d frames of %d values do not fit in the rest of the file",
				  lx->origin, lx->line, b->nframes, b->nchannels);
	b->values = malloc((want ? want : 1) * sizeof(double));
	if (!b->values)
		return mc_err_set(lx->err, "%s: out of memory for %zu values", lx->origin, want);

	/* Value lines: one frame per line, exactly nchannels numbers. */
	while (lx->p < lx->end && *lx->p != '\n')
		lx->p++; /* the rest of the Frame Time line */
	int frame = 0;
	while (lx->p < lx->end) {
		lx->p++; /* '\n' */
		lx->line++;
		const char *eol = memchr(lx->p, '\n', (size_t)(lx->end - lx->p));
		if (!eol)
			eol = lx->end;
		lexer ln = {.p = lx->p, .end = eol, .line = lx->line, .origin = lx->origin, .err = lx->err};
		int count = 0, rc;
		while ((rc = next_token(&ln, tok)) == 1) {
			double v;
			if (parse_double(tok, &v) != 0)
				return mc_err_set(lx->err, "%s:%d: frame %d: value %d: '%s' is not a number", lx->origin,
						  lx->line, frame, count + 1, tok);
			if (frame < b->nframes && count < b->nchannels)
				b->values[(size_t)frame * b->nchannels + count] = v;
			count++;
		}
		if (rc < 0)
			return -1;
		lx->p = eol;
		if (count == 0)
			continue; /* blank line */
		if (frame >= b->nframes)
			return mc_err_set(lx->err, "%s:%d: more frame lines than 'Frames: %d'", lx->origin, lx->line,
					  b->nframes);
		if (count != b->nchannels)
			return mc_err_set(lx->err, "%s:%d: frame %d has %d values, the hierarchy has %d channels",
					  lx->origin, lx->line, frame, count, b->nchannels);
		frame++;
	}
	if (frame != b->nframes)
		return mc_err_set(lx->err, "%s:%d: 'Frames: %d' but the file has %d frame lines", lx->origin, lx->line,
				  b->nframes, frame);
	return 0;
}

int mc_bvh_parse(const char *text, size_t len, const char *origin, mc_bvh *bvh, mc_err *err)
{
	memset(bvh, 0, sizeof(*bvh));
	lexer lx = {.p = text, .end = text + len, .line = 1, .origin = origin ? origin : "bvh", .err = err};
	char tok[TOKEN_MAX];
	if (parse_hierarchy(&lx, bvh, tok) != 0 || parse_motion(&lx, bvh, tok) != 0) {
		mc_bvh_free(bvh);
		return -1;
	}
	return 0;
}

int mc_bvh_load(const char *path, mc_bvh *bvh, mc_err *err)
{
	memset(bvh, 0, sizeof(*bvh));
	uint8_t *text;
	size_t got;
	/* 256 MiB: hours of motion capture at 120 Hz */
	if (mc_file_read(path, 256u << 20, &text, &got, err) < 0)
		return -1;
	int rc = mc_bvh_parse((const char *)text, got, path, bvh, err);
	free(text);
	return rc;
}

void mc_bvh_free(mc_bvh *bvh)
{
	free(bvh->joints);
	free(bvh->values);
	memset(bvh, 0, sizeof(*bvh));
}

int mc_bvh_find(const mc_bvh *bvh, const char *name)
{
	for (int i = 0; i < bvh->njoints; i++)
		if (strcmp(bvh->joints[i].name, name) == 0)
			return i;
	return -1;
}

int mc_bvh_count_joints(const mc_bvh *bvh)
{
	int n = 0;
	for (int i = 0; i < bvh->njoints; i++)
		n += !bvh->joints[i].end_site;
	return n;
}

const double *mc_bvh_frame(const mc_bvh *bvh, int frame)
{
	if (bvh->nframes == 0 || bvh->nchannels == 0)
		return NULL;
	if (frame < 0)
		frame = 0;
	if (frame >= bvh->nframes)
		frame = bvh->nframes - 1;
	return bvh->values + (size_t)frame * (size_t)bvh->nchannels;
}

void mc_bvh_fk(const mc_bvh *bvh, int frame, mc_xform *world_from_joint)
{
	const double *v = mc_bvh_frame(bvh, frame);
	for (int i = 0; i < bvh->njoints; i++) {
		const mc_bvh_joint *j = &bvh->joints[i];
		mc_xform local = {mc_m3_identity(), j->offset};
		for (int c = 0; c < j->nchannels && v; c++) {
			double x = v[j->channel0 + c];
			int ch = j->channels[c];
			if (ch <= MC_BVH_ZPOS) {
				double *t = ch == MC_BVH_XPOS ? &local.t.x : ch == MC_BVH_YPOS ? &local.t.y : &local.t.z;
				*t += x;
			} else {
				local.R = mc_m3_mul(local.R, mc_m3_rot_axis(ch - MC_BVH_XROT, x * M_PI / 180.0));
			}
		}
		world_from_joint[i] = j->parent < 0 ? local : mc_xform_compose(world_from_joint[j->parent], local);
	}
}

double mc_bvh_rest_height(const mc_bvh *bvh)
{
	if (bvh->njoints == 0)
		return 0;
	mc_xform *x = malloc(sizeof(mc_xform) * (size_t)bvh->njoints);
	if (!x)
		return 0;
	mc_bvh rest = *bvh;
	rest.nframes = 0; /* no values: every channel reads as 0 */
	mc_bvh_fk(&rest, 0, x);
	double lo = x[0].t.y, hi = x[0].t.y;
	for (int i = 1; i < bvh->njoints; i++) {
		lo = fmin(lo, x[i].t.y);
		hi = fmax(hi, x[i].t.y);
	}
	free(x);
	return hi - lo;
}

/* docs/CONVENTIONS.md name, newer CMU name, older CMU name. */
static const char *const cmu_map[MC_BVH_CMU_JOINTS][3] = {
	{"head_top", "Head_End", "Head_End"},
	{"neck", "Head", "Head"},
	{"spine", "Spine1", "Chest"},
	{"pelvis", "Hips", "Hips"},
	{"left_shoulder", "LeftArm", "LeftShoulder"},
	{"left_elbow", "LeftForeArm", "LeftElbow"},
	{"left_wrist", "LeftHand", "LeftWrist"},
	{"left_hip", "LeftUpLeg", "LeftHip"},
	{"left_knee", "LeftLeg", "LeftKnee"},
	{"left_ankle", "LeftFoot", "LeftAnkle"},
	{"left_toe", "LeftToeBase", "LeftToe"},
	{"right_shoulder", "RightArm", "RightShoulder"},
	{"right_elbow", "RightForeArm", "RightElbow"},
	{"right_wrist", "RightHand", "RightWrist"},
	{"right_hip", "RightUpLeg", "RightHip"},
	{"right_knee", "RightLeg", "RightKnee"},
	{"right_ankle", "RightFoot", "RightAnkle"},
	{"right_toe", "RightToeBase", "RightToe"},
};

const char *mc_bvh_cmu_joint_name(int i)
{
	return i >= 0 && i < MC_BVH_CMU_JOINTS ? cmu_map[i][0] : NULL;
}

int mc_bvh_map_cmu(const mc_bvh *bvh, int *bvh_index, mc_err *err)
{
	int naming = mc_bvh_find(bvh, "LeftUpLeg") >= 0 ? 1 : 2;
	for (int i = 0; i < MC_BVH_CMU_JOINTS; i++) {
		bvh_index[i] = mc_bvh_find(bvh, cmu_map[i][naming]);
		if (bvh_index[i] < 0)
			return mc_err_set(err, "no joint '%s' (for %s) in this skeleton: not a CMU skeleton in the %s naming",
					  cmu_map[i][naming], cmu_map[i][0], naming == 1 ? "newer (01_01)" : "older (131_01)");
	}
	return 0;
}

void mc_bvh_joints_in_head(const mc_bvh *bvh, const int *bvh_index, int frame, double metres_per_unit, mc_vec3 *out)
{
	mc_xform *x = malloc(sizeof(mc_xform) * (size_t)bvh->njoints);
	if (!x) {
		for (int i = 0; i < MC_BVH_CMU_JOINTS; i++)
			out[i] = mc_v3(NAN, NAN, NAN);
		return;
	}
	mc_bvh_fk(bvh, frame, x);
	const mc_xform *head = &x[bvh_index[1]];
	mc_mat3 head_from_world = mc_m3_transpose(head->R);
	for (int i = 0; i < MC_BVH_CMU_JOINTS; i++) {
		mc_vec3 q = mc_m3_apply(head_from_world, mc_v3_sub(x[bvh_index[i]].t, head->t));
		/* BVH axes (x left, y up, z forward) to the model's (x right, y down, z forward). */
		out[i] = mc_v3(-q.x * metres_per_unit, -q.y * metres_per_unit, q.z * metres_per_unit);
	}
	free(x);
}
