/* The latest-pose block from the client's side: mapping the descriptor
 * the daemon sends (GET_POSE_BLOCK), reading the newest poses under the
 * block's seqlock (../pose_block.h) and waiting for the next on its futex. */
#include "client/internal.h"

#include "pose_block.h"

#include <errno.h>
#include <limits.h>
#include <linux/futex.h>
#include <stdlib.h>
#include <sys/mman.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

#define READ_TRIES 1000000 /* a write takes microseconds; this bounds a stuck writer */

struct mocap_pose_block {
	const pose_block *b;
};

static int check_header(const pose_block *b)
{
	if (b->magic != POSE_BLOCK_MAGIC || b->version != POSE_BLOCK_VERSION || b->nslots != POSE_BLOCK_SLOTS ||
	    b->slot_bytes != POSE_BLOCK_SLOT_BYTES || b->max_joints != POSE_BLOCK_MAX_JOINTS)
		return mcl_set_err(MOCAP_E_PROTOCOL, "the daemon's pose block has another layout (version %u)",
				   b->version);
	return 0;
}

static mocap_pose_block *map_fd(int fd, uint64_t size)
{
	if (size != POSE_BLOCK_SIZE) {
		mcl_set_err(MOCAP_E_PROTOCOL, "the daemon's pose block has %llu bytes, this library expects %u",
			    (unsigned long long)size, POSE_BLOCK_SIZE);
		return NULL;
	}
	void *p = mmap(NULL, POSE_BLOCK_SIZE, PROT_READ, MAP_SHARED, fd, 0);
	if (p == MAP_FAILED) {
		mcl_set_err(MOCAP_E_SYSTEM, "mapping the pose block: %s", strerror(errno));
		return NULL;
	}
	mocap_pose_block *pb = malloc(sizeof(*pb));
	if (!pb || check_header(p) < 0) {
		if (!pb)
			mcl_set_err(MOCAP_E_SYSTEM, "out of memory");
		free(pb);
		munmap(p, POSE_BLOCK_SIZE);
		return NULL;
	}
	pb->b = p;
	return pb;
}

mocap_pose_block *mocap_pose_block_map(mocap_client *c)
{
	if (c->version < 3) { /* an older daemon would take the request as malformed */
		mcl_set_err(MOCAP_E_UNAVAILABLE, "the daemon speaks protocol version %u; the pose block needs 3",
			    c->version);
		return NULL;
	}
	proto_msg *m = mcl_new_msg(MC_MSG_GET_POSE_BLOCK);
	if (!m)
		return NULL;
	int fds[MAX_RX_FDS], nfds = 0;
	mocap_pose_block *pb = NULL;
	if (mcl_request(c, m, MC_MSG_POSE_BLOCK, m, fds, &nfds, NULL) == 0) {
		if (nfds != 1)
			mcl_set_err(MOCAP_E_PROTOCOL, "POSE_BLOCK came with %d descriptors, expected 1", nfds);
		else
			pb = map_fd(fds[0], m->u.pose_block.size);
		mcl_close_fds(fds, nfds); /* the mapping stays */
	}
	free(m);
	return pb;
}

void mocap_pose_block_unmap(mocap_pose_block *pb)
{
	if (!pb)
		return;
	munmap((void *)pb->b, POSE_BLOCK_SIZE);
	free(pb);
}

static void to_frame(const pose_block_slot *s, uint64_t now, mocap_skeleton_frame *f)
{
	f->seq = s->seq;
	f->capture_ns = s->capture_ns;
	f->publish_ns = s->publish_ns;
	f->receive_ns = now;
	f->missed = 0;
	f->skeleton_id = s->skeleton_id;
	f->state = (mocap_track_state)s->state;
	f->space = MOCAP_SPACE_RIG;
	f->njoints = s->njoints;
	for (int j = 0; j < s->njoints; j++) {
		memcpy(f->joints[j].position, s->joints[j].position, sizeof(f->joints[j].position));
		memcpy(f->joints[j].orientation, s->joints[j].orientation, sizeof(f->joints[j].orientation));
		f->joints[j].confidence = s->joints[j].confidence;
	}
}

/* The `count` newest slots into frames (newest first); how many, or an error. */
static int read_newest(const mocap_pose_block *pb, mocap_skeleton_frame *f, int count)
{
	pose_block_slot slots[2];
	int n = pose_block_read(pb->b, slots, count, READ_TRIES);
	if (n < 0)
		return mcl_set_err(MOCAP_E_TIMEOUT, "the pose block stayed busy (a writer stopped in the middle)");
	uint64_t now = mc_now_ns();
	for (int i = 0; i < n; i++)
		to_frame(&slots[i], now, &f[i]);
	return n;
}

int mocap_pose_block_read(const mocap_pose_block *pb, mocap_skeleton_frame *f)
{
	return read_newest(pb, f, 1);
}

int mocap_pose_block_wait(const mocap_pose_block *pb, uint64_t after_seq, mocap_skeleton_frame *f, int timeout_ms)
{
	uint64_t deadline = mcl_deadline_after(timeout_ms);
	_Atomic uint32_t *word = (_Atomic uint32_t *)&pb->b->seqlock;
	for (;;) {
		uint32_t lock = atomic_load_explicit(word, memory_order_acquire);
		int n = read_newest(pb, f, 1);
		if (n != 0 && (n < 0 || f->seq > after_seq))
			return n;
		uint64_t now = mc_now_ns();
		if (deadline != FOREVER && now >= deadline)
			return 0;
		struct timespec rel, *timeout = NULL;
		if (deadline != FOREVER) {
			rel.tv_sec = (time_t)((deadline - now) / MC_NS_PER_S);
			rel.tv_nsec = (long)((deadline - now) % MC_NS_PER_S);
			timeout = &rel;
		}
		/* Returns at once if the word moved on since it was read. */
		syscall(SYS_futex, word, FUTEX_WAIT, lock, timeout, NULL, 0);
	}
}

int mocap_pose_block_predict(const mocap_pose_block *pb, uint64_t t_ns, mocap_skeleton_frame *f)
{
	mocap_skeleton_frame *two = malloc(2 * sizeof(*two));
	if (!two)
		return mcl_set_err(MOCAP_E_SYSTEM, "out of memory");
	int n = read_newest(pb, two, 2);
	int rc = n < 0 ? n
		 : n == 0 ? mcl_set_err(MOCAP_E_UNAVAILABLE, "no pose published yet")
			  : mocap_predict(n == 2 ? &two[1] : NULL, &two[0], t_ns, f);
	free(two);
	return rc;
}
