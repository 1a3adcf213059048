/* take: record files of a take (docs/RECORDING.md, "Record files"). */
#include "take.h"

#include "base/mc_file.h"
#include "base/mc_le.h"
#include "image/mc_image.h"
#include "image/mc_pixfmt.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/uio.h>
#include <unistd.h>
#include <zlib.h>

/* ---- writing (every field little-endian: base/mc_le.h) ---- */

int take_file_create(take_file *f, const char *path, mc_err *err)
{
	memset(f, 0, sizeof(*f));
	snprintf(f->path, sizeof(f->path), "%s", path);
	f->fd = open(path, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0640);
	if (f->fd < 0)
		return mc_err_set(err, "%s: %s", path, strerror(errno));
	return 0;
}

int take_file_append(take_file *f, take_record_type type, const void *a, size_t an, const void *b, size_t bn,
		     uint64_t now_ns, mc_err *err)
{
	size_t size = an + bn;
	if (f->fd < 0)
		return mc_err_set(err, "%s: closed", f->path);
	if (size > TAKE_MAX_PAYLOAD)
		return mc_err_set(err, "%s: a record of %zu bytes (at most %u)", f->path, size, TAKE_MAX_PAYLOAD);
	uint8_t head[TAKE_HEADER_SIZE], *p = head;
	p = mc_le_put_u32(p, TAKE_RECORD_MAGIC);
	p = mc_le_put_u16(p, (uint16_t)type);
	p = mc_le_put_u16(p, 0);
	p = mc_le_put_u32(p, (uint32_t)size);
	uLong crc = crc32(0L, a, (uInt)an);
	p = mc_le_put_u32(p, (uint32_t)(bn ? crc32(crc, b, (uInt)bn) : crc));
	mc_le_put_u64(p, now_ns);
	struct iovec iov[3] = {{head, sizeof(head)}, {(void *)a, an}, {(void *)b, bn}};
	size_t want = sizeof(head) + size, done = 0;
	while (done < want) {
		ssize_t n = writev(f->fd, iov, 3);
		if (n < 0 && errno == EINTR)
			continue;
		if (n <= 0) {
			int e = n < 0 ? errno : ENOSPC;
			/* Cut back a partial record: the file stays whole records. */
			if (done > 0 && ftruncate(f->fd, (off_t)f->bytes) == 0)
				lseek(f->fd, (off_t)f->bytes, SEEK_SET);
			return mc_err_set(err, "%s: %s", f->path, strerror(e));
		}
		done += (size_t)n;
		for (int i = 0; i < 3; i++) { /* skip what was written */
			size_t k = (size_t)n < iov[i].iov_len ? (size_t)n : iov[i].iov_len;
			iov[i].iov_base = (uint8_t *)iov[i].iov_base + k;
			iov[i].iov_len -= k;
			n -= (ssize_t)k;
		}
	}
	f->bytes += want;
	return 0;
}

int take_file_sync(take_file *f, mc_err *err)
{
	if (f->fd < 0 || f->synced == f->bytes)
		return 0;
	if (fdatasync(f->fd) < 0)
		return mc_err_set(err, "%s: fdatasync: %s", f->path, strerror(errno));
	f->synced = f->bytes;
	return 0;
}

void take_file_close(take_file *f)
{
	if (f->fd >= 0)
		close(f->fd);
	f->fd = -1;
}

/* ---- payloads ---- */

#define DEF_HEAD 8
#define DEF_JOINT (4 + 24 + TAKE_JOINT_NAME)
#define POSE_HEAD 40
#define POSE_JOINT 64

size_t take_encode_def(const take_def *d, uint8_t *buf, size_t cap)
{
	size_t need = DEF_HEAD + (size_t)d->njoints * DEF_JOINT;
	if (cap < need || d->njoints < 0 || d->njoints > TAKE_MAX_JOINTS)
		return 0;
	uint8_t *p = mc_le_put_u32(buf, d->id);
	p = mc_le_put_u16(p, (uint16_t)d->njoints);
	p = mc_le_put_u16(p, 0);
	for (int j = 0; j < d->njoints; j++) {
		p = mc_le_put_u32(p, (uint32_t)d->joints[j].parent);
		for (int k = 0; k < 3; k++)
			p = mc_le_put_f64(p, d->joints[j].offset[k]);
		memset(p, 0, TAKE_JOINT_NAME);
		memcpy(p, d->joints[j].name, strnlen(d->joints[j].name, TAKE_JOINT_NAME - 1));
		p += TAKE_JOINT_NAME;
	}
	return need;
}

int take_decode_def(const uint8_t *p, size_t size, take_def *d)
{
	if (size < DEF_HEAD)
		return -1;
	memset(d, 0, sizeof(*d));
	d->id = mc_le_u32(p);
	d->njoints = mc_le_u16(p + 4);
	if (d->njoints > TAKE_MAX_JOINTS || size != DEF_HEAD + (size_t)d->njoints * DEF_JOINT)
		return -1;
	p += DEF_HEAD;
	for (int j = 0; j < d->njoints; j++, p += DEF_JOINT) {
		d->joints[j].parent = (int)mc_le_u32(p);
		if (d->joints[j].parent >= j || d->joints[j].parent < -1)
			return -1; /* parents come first */
		for (int k = 0; k < 3; k++)
			d->joints[j].offset[k] = mc_le_f64(p + 4 + 8 * k);
		memcpy(d->joints[j].name, p + 28, TAKE_JOINT_NAME - 1);
	}
	return 0;
}

size_t take_encode_pose(const take_pose *o, uint8_t *buf, size_t cap)
{
	size_t joints_end = POSE_HEAD + (size_t)o->njoints * POSE_JOINT;
	size_t need = joints_end + (o->ndof > 0 ? 4 + 8 * (size_t)o->ndof : 0);
	if (cap < need || o->njoints < 0 || o->njoints > TAKE_MAX_JOINTS || o->ndof < 0 || o->ndof > TAKE_MAX_DOF)
		return 0;
	uint8_t *p = mc_le_put_u64(buf, o->seq);
	p = mc_le_put_u64(p, o->capture_ns);
	p = mc_le_put_u64(p, o->realtime_ns);
	p = mc_le_put_u32(p, (uint32_t)o->state);
	p = mc_le_put_u32(p, o->def_id);
	p = mc_le_put_u16(p, (uint16_t)o->njoints);
	p = mc_le_put_u16(p, 0);
	p = mc_le_put_u32(p, 0);
	for (int j = 0; j < o->njoints; j++) {
		for (int k = 0; k < 3; k++)
			p = mc_le_put_f64(p, o->joints[j].position[k]);
		for (int k = 0; k < 4; k++)
			p = mc_le_put_f64(p, o->joints[j].orientation[k]);
		p = mc_le_put_f32(p, o->joints[j].confidence);
		p = mc_le_put_u32(p, 0);
	}
	if (o->ndof > 0) { /* optional: the tracker's pose vector */
		p = mc_le_put_u16(p, (uint16_t)o->ndof);
		p = mc_le_put_u16(p, 0);
		for (int k = 0; k < o->ndof; k++)
			p = mc_le_put_f64(p, o->dofs[k]);
	}
	return need;
}

int take_decode_pose(const uint8_t *p, size_t size, take_pose *o)
{
	if (size < POSE_HEAD)
		return -1;
	o->seq = mc_le_u64(p);
	o->capture_ns = mc_le_u64(p + 8);
	o->realtime_ns = mc_le_u64(p + 16);
	o->state = (int)mc_le_u32(p + 24);
	o->def_id = mc_le_u32(p + 28);
	o->njoints = mc_le_u16(p + 32);
	size_t joints_end = POSE_HEAD + (size_t)o->njoints * POSE_JOINT;
	o->ndof = 0;
	if (o->njoints > TAKE_MAX_JOINTS || size < joints_end)
		return -1;
	if (size > joints_end) {
		o->ndof = size >= joints_end + 4 ? mc_le_u16(p + joints_end) : -1;
		if (o->ndof < 1 || o->ndof > TAKE_MAX_DOF || size != joints_end + 4 + 8 * (size_t)o->ndof)
			return -1;
		for (int k = 0; k < o->ndof; k++)
			o->dofs[k] = mc_le_f64(p + joints_end + 4 + 8 * k);
	}
	p += POSE_HEAD;
	for (int j = 0; j < o->njoints; j++, p += POSE_JOINT) {
		for (int k = 0; k < 3; k++)
			o->joints[j].position[k] = mc_le_f64(p + 8 * k);
		for (int k = 0; k < 4; k++)
			o->joints[j].orientation[k] = mc_le_f64(p + 24 + 8 * k);
		o->joints[j].confidence = mc_le_f32(p + 56);
	}
	return 0;
}

size_t take_encode_gap(uint64_t first_seq, uint64_t count, uint8_t *buf, size_t cap)
{
	if (cap < 16)
		return 0;
	mc_le_put_u64(mc_le_put_u64(buf, first_seq), count);
	return 16;
}

int take_decode_gap(const uint8_t *p, size_t size, uint64_t *first_seq, uint64_t *count)
{
	if (size != 16)
		return -1;
	*first_seq = mc_le_u64(p);
	*count = mc_le_u64(p + 8);
	return 0;
}

#define KP_HEAD 24
#define KP_SIZE 16

size_t take_encode_keypoints(uint64_t seq, uint64_t capture_ns, const take_keypoint *kp, int n, uint8_t *buf,
			     size_t cap)
{
	size_t need = KP_HEAD + (size_t)n * KP_SIZE;
	if (n < 0 || n > TAKE_MAX_KEYPOINTS || cap < need)
		return 0;
	uint8_t *p = mc_le_put_u64(mc_le_put_u64(buf, seq), capture_ns);
	p = mc_le_put_u32(mc_le_put_u32(p, (uint32_t)n), 0);
	for (int k = 0; k < n; k++) {
		p = mc_le_put_u16(mc_le_put_u16(p, kp[k].cam), kp[k].joint);
		p = mc_le_put_f32(mc_le_put_f32(mc_le_put_f32(p, kp[k].u), kp[k].v), kp[k].confidence);
	}
	return need;
}

int take_decode_keypoints(const uint8_t *p, size_t size, uint64_t *seq, uint64_t *capture_ns, take_keypoint *kp,
			  int cap, int *n)
{
	if (size < KP_HEAD)
		return -1;
	uint32_t count = mc_le_u32(p + 16);
	if (count > TAKE_MAX_KEYPOINTS || size != KP_HEAD + (size_t)count * KP_SIZE)
		return -1;
	*seq = mc_le_u64(p);
	*capture_ns = mc_le_u64(p + 8);
	*n = (int)count < cap ? (int)count : cap;
	for (int k = 0; k < *n; k++) {
		const uint8_t *e = p + KP_HEAD + (size_t)k * KP_SIZE;
		kp[k] = (take_keypoint){mc_le_u16(e), mc_le_u16(e + 2), mc_le_f32(e + 4), mc_le_f32(e + 8), mc_le_f32(e + 12)};
	}
	return 0;
}

void take_encode_head_pose(const take_head_pose *h, uint8_t *buf)
{
	uint8_t *p = mc_le_put_u64(buf, h->timestamp_ns);
	for (int k = 0; k < 3; k++)
		p = mc_le_put_f64(p, h->position[k]);
	for (int k = 0; k < 4; k++)
		p = mc_le_put_f64(p, h->orientation[k]);
}

int take_decode_head_pose(const uint8_t *p, size_t size, take_head_pose *h)
{
	if (size != TAKE_HEAD_POSE_SIZE)
		return -1;
	h->timestamp_ns = mc_le_u64(p);
	for (int k = 0; k < 3; k++)
		h->position[k] = mc_le_f64(p + 8 + 8 * k);
	for (int k = 0; k < 4; k++)
		h->orientation[k] = mc_le_f64(p + 32 + 8 * k);
	return 0;
}

void take_encode_frame_meta(const take_frame_meta *m, uint8_t *buf)
{
	uint8_t *p = mc_le_put_u64(buf, m->sequence);
	p = mc_le_put_u64(p, m->capture_ns);
	p = mc_le_put_u64(p, m->realtime_ns);
	p = mc_le_put_u64(p, m->driver_sequence);
	p = mc_le_put_u32(p, m->pixfmt);
	p = mc_le_put_u32(p, m->width);
	p = mc_le_put_u32(p, m->height);
	p = mc_le_put_u32(p, m->stride);
	p = mc_le_put_u32(p, m->flags);
	mc_le_put_u32(p, 0);
}

int take_decode_frame_meta(const uint8_t *p, size_t size, take_frame_meta *m)
{
	if (size < TAKE_FRAME_META_SIZE)
		return -1;
	m->sequence = mc_le_u64(p);
	m->capture_ns = mc_le_u64(p + 8);
	m->realtime_ns = mc_le_u64(p + 16);
	m->driver_sequence = mc_le_u64(p + 24);
	m->pixfmt = mc_le_u32(p + 32);
	m->width = mc_le_u32(p + 36);
	m->height = mc_le_u32(p + 40);
	m->stride = mc_le_u32(p + 44);
	m->flags = mc_le_u32(p + 48);
	return 0;
}

int take_frame_check_raw(const take_frame_meta *m, size_t n, mc_err *err)
{
	int bpp = mc_image_bytes_per_pixel(m->pixfmt);
	if (bpp == 0)
		return mc_err_set(err, "pixfmt: %u (%s) is not a raw format", m->pixfmt, mc_pixfmt_name(m->pixfmt));
	if (m->width < 1 || m->width > TAKE_MAX_FRAME_SIDE || m->height < 1 || m->height > TAKE_MAX_FRAME_SIDE)
		return mc_err_set(err, "width x height: %ux%u, not within 1..%d a side", m->width, m->height,
				  TAKE_MAX_FRAME_SIDE);
	uint64_t row = (uint64_t)m->width * (uint64_t)bpp, stride = m->stride ? m->stride : row;
	if (stride < row)
		return mc_err_set(err, "stride: %u bytes, a row of %u %s pixels takes %llu", m->stride, m->width,
				  mc_pixfmt_name(m->pixfmt), (unsigned long long)row);
	uint64_t need = (m->height - 1) * stride + row;
	if (need > n)
		return mc_err_set(err, "%ux%u %s needs %llu bytes, the record holds %zu", m->width, m->height,
				  mc_pixfmt_name(m->pixfmt), (unsigned long long)need, n);
	return 0;
}

/* ---- reading ---- */

int take_reader_open(take_reader *r, const char *path, mc_err *err)
{
	memset(r, 0, sizeof(*r));
	snprintf(r->path, sizeof(r->path), "%s", path);
	/* Regular files only: a FIFO would block the open, or the reading,
	 * for ever (mocap-export, the take driver, mocapd --check). */
	r->f = mc_file_open_regular(path, err);
	if (!r->f)
		return -1;
	struct stat st;
	if (fstat(fileno(r->f), &st) < 0) {
		int e = errno;
		fclose(r->f);
		r->f = NULL;
		return mc_err_set(err, "%s: %s", path, strerror(e));
	}
	r->size = (uint64_t)st.st_size;
	return 0;
}

void take_reader_close(take_reader *r)
{
	if (r->f)
		fclose(r->f);
	r->f = NULL;
	free(r->buf);
	r->buf = NULL;
}

/* Reads n bytes at the current position; false at the end of the file. */
static bool read_exact(take_reader *r, void *dst, size_t n)
{
	return n == 0 || fread(dst, 1, n, r->f) == n;
}

int take_reader_next(take_reader *r, take_record_type *type, const uint8_t **payload, size_t *size,
		     uint64_t *written_ns)
{
	r->valid_end = r->pos;
	if (r->pos == r->size)
		return 0;
	uint8_t h[TAKE_HEADER_SIZE];
	uint32_t n = 0;
	bool ok = read_exact(r, h, sizeof(h)) && mc_le_u32(h) == TAKE_RECORD_MAGIC &&
		  (n = mc_le_u32(h + 8)) <= TAKE_MAX_PAYLOAD && n <= r->size - r->pos - TAKE_HEADER_SIZE;
	if (ok && n > r->cap) {
		uint8_t *grown = realloc(r->buf, n);
		ok = grown != NULL;
		if (ok) {
			r->buf = grown;
			r->cap = n;
		}
	}
	if (!ok || !read_exact(r, r->buf, n) || crc32(0L, r->buf, n) != mc_le_u32(h + 12)) {
		r->torn = true;
		return 0;
	}
	*type = (take_record_type)mc_le_u16(h + 4);
	*payload = r->buf;
	*size = n;
	if (written_ns)
		*written_ns = mc_le_u64(h + 16);
	r->pos += TAKE_HEADER_SIZE + n;
	r->valid_end = r->pos;
	return 1;
}

int take_reader_next_frame(take_reader *r, take_frame_meta *m, const uint8_t **bytes, size_t *n)
{
	take_record_type type;
	const uint8_t *p;
	size_t size;
	while (take_reader_next(r, &type, &p, &size, NULL) == 1)
		if (type == TAKE_FRAME && take_decode_frame_meta(p, size, m) == 0) {
			*bytes = p + TAKE_FRAME_META_SIZE;
			*n = size - TAKE_FRAME_META_SIZE;
			return 1;
		}
	return 0;
}

/* ---- poses of a take ---- */

int take_poses_load(const char *dir, const char *track, take_poses *out, mc_err *err)
{
	memset(out, 0, sizeof(*out));
	char path[4300];
	if (track)
		snprintf(path, sizeof(path), "%s/poses-%.64s.mcr", dir, track);
	else
		snprintf(path, sizeof(path), "%s/poses.mcr", dir);
	take_reader r;
	if (take_reader_open(&r, path, err) < 0)
		return -1;
	take_record_type type;
	const uint8_t *p;
	size_t n;
	int cap = 0;
	bool have_def = false;
	while (take_reader_next(&r, &type, &p, &n, NULL) == 1) {
		if (type == TAKE_DEF && !have_def) {
			if (take_decode_def(p, n, &out->def) < 0)
				goto bad;
			have_def = true;
		} else if (type == TAKE_SKELETON) {
			if (out->nposes == cap) {
				cap = cap ? cap * 2 : 256;
				take_pose *grown = realloc(out->poses, (size_t)cap * sizeof(*grown));
				if (!grown)
					goto bad;
				out->poses = grown;
			}
			take_pose *pose = &out->poses[out->nposes];
			memset(pose, 0, sizeof(*pose));
			if (take_decode_pose(p, n, pose) < 0)
				goto bad;
			out->nposes++;
		} else if (type == TAKE_GAP) {
			uint64_t first, count;
			if (take_decode_gap(p, n, &first, &count) < 0)
				goto bad;
			/* saturates: crafted counts must not wrap to a small total */
			out->gap_frames = count > UINT64_MAX - out->gap_frames ? UINT64_MAX : out->gap_frames + count;
		}
	}
	out->torn = r.torn;
	take_reader_close(&r);
	if (!have_def) {
		take_poses_free(out);
		return mc_err_set(err, "%s: no skeleton definition (an empty take?)", path);
	}
	/* Every reader walks the definition's joints and a skeleton's together
	 * (names, parents, rotations): a count that differs is a damaged or
	 * crafted take, refused whole (issue 34: mocap-track crashed, the BVH
	 * export read memory never written). */
	for (int i = 0; i < out->nposes; i++)
		if (out->poses[i].njoints != out->def.njoints) {
			int n = out->poses[i].njoints;
			unsigned long long seq = (unsigned long long)out->poses[i].seq;
			take_poses_free(out);
			return mc_err_set(err, "%s: skeleton %d (seq %llu): %d joints, the skeleton definition has %d",
					  path, i + 1, seq, n, out->def.njoints);
		}
	return 0;
bad:
	take_reader_close(&r);
	take_poses_free(out);
	return mc_err_set(err, "%s: the record ending at byte %llu does not decode", path,
			  (unsigned long long)r.valid_end);
}

void take_poses_free(take_poses *t)
{
	free(t->poses);
	t->poses = NULL;
	t->nposes = 0;
}
