/* The graph file (docs/MOTION_GRAPH.md, "Graph file"): little-endian
 * binary, a fixed header, then the skeleton, clips, frames, edges and
 * parametric nodes, and a CRC-32 of everything before it. */
#include "motion/mc_motion_graph.h"
#include "base/mc_le.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- CRC-32 (IEEE 802.3, as zlib's crc32) ---- */
static uint32_t crc32_update(uint32_t crc, const uint8_t *p, size_t n)
{
	crc = ~crc;
	while (n--) {
		crc ^= *p++;
		for (int k = 0; k < 8; k++)
			crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1)));
	}
	return ~crc;
}

/* ---- a growing byte buffer ---- */
typedef struct {
	uint8_t *p;
	size_t n, cap;
	int oom;
} buf;

static void put(buf *b, const void *v, size_t n)
{
	if (b->oom)
		return;
	if (b->n + n > b->cap) {
		size_t cap = b->cap ? b->cap * 2 : 1 << 16;
		while (cap < b->n + n)
			cap *= 2;
		uint8_t *q = realloc(b->p, cap);
		if (!q) {
			b->oom = 1;
			return;
		}
		b->p = q;
		b->cap = cap;
	}
	memcpy(b->p + b->n, v, n);
	b->n += n;
}

static void put_u32(buf *b, uint32_t v)
{
	uint8_t x[4];
	mc_le_put_u32(x, v);
	put(b, x, 4);
}

static void put_u8(buf *b, uint8_t v) { put(b, &v, 1); }

static void put_f32(buf *b, float f)
{
	uint8_t x[4];
	mc_le_put_f32(x, f);
	put(b, x, 4);
}

static void put_f64(buf *b, double d)
{
	uint8_t x[8];
	mc_le_put_f64(x, d);
	put(b, x, 8);
}

static void put_str(buf *b, const char *s, size_t width)
{
	char tmp[MC_MOTION_NAME_MAX] = {0};
	snprintf(tmp, sizeof(tmp), "%s", s);
	put(b, tmp, width);
}

int mc_graph_save(const mc_motion_graph *g, const char *path, mc_err *err)
{
	const mc_motion_db *db = &g->db;
	buf b = {0};
	put(&b, MC_GRAPH_MAGIC, 8);
	put_u32(&b, MC_GRAPH_VERSION);
	put_u32(&b, MC_MOTION_JOINTS);
	put_f64(&b, db->fps);
	put_f64(&b, g->alpha);
	put_f64(&b, g->tau);
	put_u32(&b, (uint32_t)g->lmin);
	put_u32(&b, (uint32_t)g->lmax);
	put_u32(&b, (uint32_t)g->lstep);
	put_u32(&b, (uint32_t)db->nclips);
	put_u32(&b, (uint32_t)db->nframes);
	put_u32(&b, (uint32_t)g->nedges);
	put_u32(&b, (uint32_t)g->nparams);
	put_u32(&b, (uint32_t)g->nparam_edges);
	for (int j = 0; j < MC_MOTION_JOINTS; j++) {
		put_u32(&b, (uint32_t)db->skel.parent[j]);
		put_f64(&b, db->skel.offset[j].x);
		put_f64(&b, db->skel.offset[j].y);
		put_f64(&b, db->skel.offset[j].z);
	}
	for (int c = 0; c < db->nclips; c++) {
		put_str(&b, db->clips[c].name, MC_MOTION_NAME_MAX);
		put_str(&b, db->clips[c].cls, MC_MOTION_CLASS_MAX);
		put_u32(&b, (uint32_t)db->clips[c].first);
		put_u32(&b, (uint32_t)db->clips[c].nframes);
	}
	for (size_t i = 0; i < (size_t)db->nframes * MC_MOTION_JOINTS; i++) {
		put_f32(&b, (float)db->pos[i].x);
		put_f32(&b, (float)db->pos[i].y);
		put_f32(&b, (float)db->pos[i].z);
	}
	for (int i = 0; i < g->nedges; i++) {
		const mc_edge *e = &g->edges[i];
		put_u32(&b, e->from);
		put_u32(&b, e->to);
		put_f32(&b, e->D);
		put_f32(&b, e->E);
		put_u8(&b, e->L);
		put_u8(&b, e->li);
		put_u8(&b, e->lj);
		put_u8(&b, e->flags);
	}
	for (int k = 0; k < g->nparams; k++) {
		const mc_param_node *pn = &g->params[k];
		put_str(&b, pn->cls, MC_MOTION_CLASS_MAX);
		put_u32(&b, (uint32_t)pn->nmembers);
		for (int i = 0; i < pn->nmembers; i++) {
			put_u32(&b, (uint32_t)pn->clip[i]);
			put_f32(&b, pn->speed[i]);
			put_f32(&b, pn->turn[i]);
		}
	}
	for (int k = 0; k < g->nparam_edges; k++) {
		const mc_param_edge *pe = &g->param_edges[k];
		put_u32(&b, pe->from_node);
		put_u32(&b, pe->to_node);
		put_u32(&b, pe->from);
		put_u32(&b, pe->to);
		put_f32(&b, pe->E);
	}
	put_u32(&b, crc32_update(0, b.p, b.n));
	if (b.oom) {
		free(b.p);
		return mc_err_set(err, "%s: out of memory", path);
	}
	FILE *f = fopen(path, "wb");
	if (!f) {
		free(b.p);
		return mc_err_set(err, "%s: %s", path, strerror(errno));
	}
	size_t w = fwrite(b.p, 1, b.n, f);
	int bad = w != b.n || ferror(f);
	bad |= fclose(f) != 0;
	free(b.p);
	return bad ? mc_err_set(err, "%s: write error", path) : 0;
}

/* ---- reading ---- */
typedef struct {
	const uint8_t *p;
	size_t n, at;
	const char *path;
	mc_err *err;
	int bad;
} rd;

static const uint8_t *take(rd *r, size_t n, const char *what)
{
	if (r->bad)
		return NULL;
	if (n > r->n - r->at) {
		r->bad = 1;
		mc_err_set(r->err, "%s: truncated at byte %zu (reading %s)", r->path, r->at, what);
		return NULL;
	}
	const uint8_t *q = r->p + r->at;
	r->at += n;
	return q;
}

static uint32_t get_u32(rd *r, const char *what)
{
	const uint8_t *q = take(r, 4, what);
	return q ? mc_le_u32(q) : 0;
}

static uint8_t get_u8(rd *r, const char *what)
{
	const uint8_t *q = take(r, 1, what);
	return q ? *q : 0;
}

static float get_f32(rd *r, const char *what)
{
	const uint8_t *q = take(r, 4, what);
	return q ? mc_le_f32(q) : 0;
}

static double get_f64(rd *r, const char *what)
{
	const uint8_t *q = take(r, 8, what);
	return q ? mc_le_f64(q) : 0;
}

static void get_str(rd *r, char *out, size_t width, const char *what)
{
	const uint8_t *q = take(r, width, what);
	if (!q)
		return;
	memcpy(out, q, width);
	out[width - 1] = 0;
}

static int fail(rd *r, const char *fmt, const char *field, long v)
{
	r->bad = 1;
	char msg[256];
	snprintf(msg, sizeof(msg), fmt, v);
	return mc_err_set(r->err, "%s: %s: %s", r->path, field, msg);
}

static int failf(rd *r, const char *field, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static int failf(rd *r, const char *field, const char *fmt, ...)
{
	r->bad = 1;
	char msg[256];
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(msg, sizeof(msg), fmt, ap);
	va_end(ap);
	return mc_err_set(r->err, "%s: %s: %s", r->path, field, msg);
}

/* ---- values: what the checksum cannot vouch for ----
 * A file with a valid checksum may still hold NaN, infinite or absurd
 * numbers (written by another program, or crafted): NaN positions reached
 * mocapd's FRAMEs and its clients (issue 34), negative edge costs would
 * break the shortest paths. */
#define MAX_POSITION_M 1e4 /* a joint 10 km from the origin is not motion capture */
#define MAX_OFFSET_M 10.0  /* a bone */

static bool finite_within(double v, double lim) { return isfinite(v) && fabs(v) <= lim; }

static bool cost_ok(double c) { return isfinite(c) && c >= 0; }

static int check_positions(rd *r, const mc_motion_db *db)
{
	for (int j = 0; j < MC_MOTION_JOINTS; j++) {
		mc_vec3 o = db->skel.offset[j];
		if (!finite_within(o.x, MAX_OFFSET_M) || !finite_within(o.y, MAX_OFFSET_M) || !finite_within(o.z, MAX_OFFSET_M))
			return failf(r, "skeleton", "joint %d (%s): offset (%g, %g, %g) is not finite, or beyond %g m", j,
				     mc_motion_joint_name(j), o.x, o.y, o.z, MAX_OFFSET_M);
	}
	for (size_t i = 0; i < (size_t)db->nframes * MC_MOTION_JOINTS; i++) {
		mc_vec3 p = db->pos[i];
		if (!finite_within(p.x, MAX_POSITION_M) || !finite_within(p.y, MAX_POSITION_M) ||
		    !finite_within(p.z, MAX_POSITION_M))
			return failf(r, "frames", "frame %zu, joint %s: position (%g, %g, %g) is not finite, or beyond %g m",
				     i / MC_MOTION_JOINTS, mc_motion_joint_name((int)(i % MC_MOTION_JOINTS)), p.x, p.y, p.z,
				     MAX_POSITION_M);
	}
	return 0;
}

static int check_costs(rd *r, const mc_motion_graph *g)
{
	for (int i = 0; i < g->nedges; i++)
		if (!cost_ok(g->edges[i].D) || !cost_ok(g->edges[i].E))
			return failf(r, "edges", "edge %d: cost D %g, E %g: costs must be finite and not negative", i,
				     (double)g->edges[i].D, (double)g->edges[i].E);
	for (int k = 0; k < g->nparams; k++)
		for (int i = 0; i < g->params[k].nmembers; i++)
			if (!isfinite(g->params[k].speed[i]) || !isfinite(g->params[k].turn[i]))
				return failf(r, "params", "node %d, member %d: speed %g, turn %g: not finite", k, i,
					     (double)g->params[k].speed[i], (double)g->params[k].turn[i]);
	for (int k = 0; k < g->nparam_edges; k++)
		if (!cost_ok(g->param_edges[k].E))
			return failf(r, "param_edges", "edge %d: cost E %g: costs must be finite and not negative", k,
				     (double)g->param_edges[k].E);
	return 0;
}

static int read_file(const char *path, uint8_t **data, size_t *n, mc_err *err)
{
	FILE *f = fopen(path, "rb");
	if (!f)
		return mc_err_set(err, "%s: %s", path, strerror(errno));
	size_t cap = 1 << 16, len = 0;
	uint8_t *p = malloc(cap);
	for (size_t got; p; len += got) {
		if (len == cap) {
			uint8_t *q = realloc(p, cap * 2);
			if (!q) {
				free(p);
				p = NULL;
				break;
			}
			p = q;
			cap *= 2;
		}
		got = fread(p + len, 1, cap - len, f);
		if (got == 0)
			break;
	}
	int bad = ferror(f);
	fclose(f);
	if (!p || bad) {
		free(p);
		return mc_err_set(err, "%s: %s", path, p ? "read error" : "out of memory");
	}
	*data = p;
	*n = len;
	return 0;
}

static int read_header(rd *r, mc_motion_graph *g, uint32_t *counts)
{
	const uint8_t *magic = take(r, 8, "magic");
	if (!magic)
		return -1;
	if (memcmp(magic, MC_GRAPH_MAGIC, 8) != 0)
		return fail(r, "not a graph file (magic is not \"" MC_GRAPH_MAGIC "\")%.0ld", "magic", 0);
	uint32_t version = get_u32(r, "version");
	if (!r->bad && version != MC_GRAPH_VERSION)
		return fail(r, "%ld is not supported (this reader knows version " "1" ")", "version", (long)version);
	uint32_t joints = get_u32(r, "joints");
	if (!r->bad && joints != MC_MOTION_JOINTS)
		return fail(r, "%ld (expected 18)", "joints", (long)joints);
	double fps = get_f64(r, "fps");
	g->alpha = get_f64(r, "alpha");
	g->tau = get_f64(r, "tau");
	g->lmin = (int)get_u32(r, "lmin");
	g->lmax = (int)get_u32(r, "lmax");
	g->lstep = (int)get_u32(r, "lstep");
	for (int i = 0; i < 5; i++)
		counts[i] = get_u32(r, "counts");
	if (r->bad)
		return -1;
	/* 1e-300 passed "> 0" and gave a frame every 10^292 years */
	if (!(fps >= 1 && fps <= 1000))
		return failf(r, "fps", "%g: not a frame rate (1..1000 per second)", fps);
	if (!cost_ok(g->alpha) || !cost_ok(g->tau))
		return failf(r, "alpha, tau", "%g, %g: must be finite and not negative", g->alpha, g->tau);
	mc_motion_db_init(&g->db, fps, NULL);
	/* each count against the bytes that are left: no huge allocation for
	 * a corrupt count */
	size_t left = r->n - r->at;
	static const char *const names[5] = {"clips", "frames", "edges", "params", "param_edges"};
	static const size_t min_size[5] = {MC_MOTION_NAME_MAX + MC_MOTION_CLASS_MAX + 8, 12 * MC_MOTION_JOINTS, 20,
					   MC_MOTION_CLASS_MAX + 4, 20};
	for (int i = 0; i < 5; i++)
		if (counts[i] > left / min_size[i])
			return fail(r, "%ld is more than the file holds (truncated or damaged)", names[i], (long)counts[i]);
	return 0;
}

static int read_body(rd *r, mc_motion_graph *g, const uint32_t *counts)
{
	mc_motion_db *db = &g->db;
	for (int j = 0; j < MC_MOTION_JOINTS; j++) {
		db->skel.parent[j] = (int)get_u32(r, "skeleton");
		db->skel.offset[j].x = get_f64(r, "skeleton");
		db->skel.offset[j].y = get_f64(r, "skeleton");
		db->skel.offset[j].z = get_f64(r, "skeleton");
		if (!r->bad && (db->skel.parent[j] >= j || (j > 0 && db->skel.parent[j] < 0)))
			return fail(r, "joint %ld: parent out of order", "skeleton", j);
	}
	db->nclips = (int)counts[0];
	db->nframes = (int)counts[1];
	db->clips = calloc(counts[0] ? counts[0] : 1, sizeof(mc_motion_clip));
	db->pos = malloc(sizeof(mc_vec3) * ((size_t)counts[1] * MC_MOTION_JOINTS + 1));
	db->clip_of = malloc(sizeof(int) * ((size_t)counts[1] + 1));
	g->edges = malloc(sizeof(mc_edge) * ((size_t)counts[2] + 1));
	g->params = calloc((size_t)counts[3] + 1, sizeof(mc_param_node));
	g->param_edges = malloc(sizeof(mc_param_edge) * ((size_t)counts[4] + 1));
	if (!db->clips || !db->pos || !db->clip_of || !g->edges || !g->params || !g->param_edges)
		return fail(r, "out of memory%.0ld", "file", 0);
	int next = 0;
	for (int c = 0; c < db->nclips; c++) {
		mc_motion_clip *cl = &db->clips[c];
		get_str(r, cl->name, MC_MOTION_NAME_MAX, "clips");
		get_str(r, cl->cls, MC_MOTION_CLASS_MAX, "clips");
		cl->first = (int)get_u32(r, "clips");
		cl->nframes = (int)get_u32(r, "clips");
		if (!r->bad && (cl->first != next || cl->nframes < 1 || cl->nframes > db->nframes - next))
			return fail(r, "clip %ld: frame range does not follow the previous clip's", "clips", c);
		for (int k = 0; k < cl->nframes && !r->bad; k++)
			db->clip_of[next + k] = c;
		next += cl->nframes;
	}
	if (!r->bad && next != db->nframes)
		return fail(r, "the clips cover %ld frames, not the frame count", "clips", next);
	for (size_t i = 0; i < (size_t)db->nframes * MC_MOTION_JOINTS && !r->bad; i++) {
		double x = get_f32(r, "frames"), y = get_f32(r, "frames"), z = get_f32(r, "frames");
		db->pos[i] = mc_v3(x, y, z);
	}
	g->nedges = (int)counts[2];
	for (int i = 0; i < g->nedges && !r->bad; i++) {
		mc_edge *e = &g->edges[i];
		e->from = get_u32(r, "edges");
		e->to = get_u32(r, "edges");
		e->D = get_f32(r, "edges");
		e->E = get_f32(r, "edges");
		e->L = get_u8(r, "edges");
		e->li = get_u8(r, "edges");
		e->lj = get_u8(r, "edges");
		e->flags = get_u8(r, "edges");
		if (r->bad)
			break;
		if (e->from >= (uint32_t)db->nframes || e->to >= (uint32_t)db->nframes)
			return fail(r, "edge %ld: a frame out of range", "edges", i);
		if (i > 0 && (e->from < e[-1].from || (e->from == e[-1].from && e->to <= e[-1].to)))
			return fail(r, "edge %ld: not sorted by (from, to)", "edges", i);
		if (!(e->flags & MC_EDGE_ORIGINAL) &&
		    (e->li < 1 || e->lj < 1 || e->li > MC_DTW_MAX_WINDOW || e->lj > MC_DTW_MAX_WINDOW ||
		     (int)e->from + e->li > db->clips[db->clip_of[e->from]].first + db->clips[db->clip_of[e->from]].nframes ||
		     (int)e->to - e->lj + 1 < db->clips[db->clip_of[e->to]].first))
			return fail(r, "edge %ld: windows do not fit their clips", "edges", i);
		if ((e->flags & MC_EDGE_ORIGINAL) && (e->to != e->from + 1 || db->clip_of[e->to] != db->clip_of[e->from]))
			return fail(r, "edge %ld: an original edge that does not follow its clip", "edges", i);
	}
	g->nparams = (int)counts[3];
	for (int k = 0; k < g->nparams && !r->bad; k++) {
		mc_param_node *pn = &g->params[k];
		get_str(r, pn->cls, MC_MOTION_CLASS_MAX, "params");
		pn->nmembers = (int)get_u32(r, "params");
		if (!r->bad && (pn->nmembers < 1 || pn->nmembers > MC_PARAM_MAX_MEMBERS))
			return fail(r, "node %ld: member count out of range", "params", k);
		for (int i = 0; i < pn->nmembers && !r->bad; i++) {
			pn->clip[i] = (int)get_u32(r, "params");
			pn->speed[i] = get_f32(r, "params");
			pn->turn[i] = get_f32(r, "params");
			if (!r->bad && (pn->clip[i] < 0 || pn->clip[i] >= db->nclips))
				return fail(r, "node %ld: a clip out of range", "params", k);
		}
	}
	g->nparam_edges = (int)counts[4];
	for (int k = 0; k < g->nparam_edges && !r->bad; k++) {
		mc_param_edge *pe = &g->param_edges[k];
		pe->from_node = get_u32(r, "param_edges");
		pe->to_node = get_u32(r, "param_edges");
		pe->from = get_u32(r, "param_edges");
		pe->to = get_u32(r, "param_edges");
		pe->E = get_f32(r, "param_edges");
		if (!r->bad && (pe->from_node >= (uint32_t)g->nparams || pe->to_node >= (uint32_t)g->nparams ||
				pe->from >= (uint32_t)db->nframes || pe->to >= (uint32_t)db->nframes))
			return fail(r, "edge %ld: out of range", "param_edges", k);
	}
	return r->bad ? -1 : 0;
}

int mc_graph_load(const char *path, mc_motion_graph *g, mc_err *err)
{
	memset(g, 0, sizeof(*g));
	uint8_t *data = NULL;
	size_t n = 0;
	if (read_file(path, &data, &n, err))
		return -1;
	rd r = {data, n, 0, path, err, 0};
	uint32_t counts[5];
	int rc = read_header(&r, g, counts);
	/* the checksum before the body: a damaged file is told as such, not
	 * by whatever field the damage happens to hit */
	if (!rc && n < r.at + 4)
		rc = mc_err_set(err, "%s: truncated after the header (%zu bytes)", path, n);
	if (!rc) {
		const uint8_t *t = data + n - 4;
		uint32_t crc = mc_le_u32(t);
		if (crc != crc32_update(0, data, n - 4))
			rc = mc_err_set(err, "%s: checksum: does not match the contents (a damaged or truncated file)", path);
	}
	if (!rc) {
		r.n = n - 4;
		rc = read_body(&r, g, counts);
	}
	if (!rc)
		rc = check_positions(&r, &g->db) || check_costs(&r, g) ? -1 : 0;
	if (!rc && r.at != r.n)
		rc = mc_err_set(err, "%s: %zu bytes between the last section and the checksum", path, r.n - r.at);
	free(data);
	if (rc)
		mc_graph_free(g);
	return rc;
}
