/* The latest-pose block (../pose_block.h): a memfd the server writes every
 * published skeleton into, under a seqlock, from the publishing thread's
 * srv_publish (no hop through the server thread), and clients map
 * read-only.  After each write the futex word is woken, so a reader
 * blocked in mocap_pose_block_wait has the pose within microseconds. */
#include "server/internal.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <linux/futex.h>
#include <stdio.h>
#include <sys/mman.h>
#include <sys/syscall.h>
#include <unistd.h>

/* The writable mapping is the only one that may write: a client given the
 * descriptor (or reopening it through /proc) cannot map it writable. */
static int seal_and_share(srv_server *srv, int fd, mc_err *err)
{
	if (fcntl(fd, F_ADD_SEALS, F_SEAL_FUTURE_WRITE | F_SEAL_SEAL) != 0)
		return mc_err_set(err, "pose block: sealing: %s", strerror(errno));
	char proc[64];
	snprintf(proc, sizeof(proc), "/proc/self/fd/%d", fd);
	srv->pose_fd = open(proc, O_RDONLY | O_CLOEXEC);
	if (srv->pose_fd < 0)
		return mc_err_set(err, "pose block: reopening read-only: %s", strerror(errno));
	return 0;
}

int srv_pose_open(srv_server *srv, mc_err *err)
{
	int fd = memfd_create("mocapd-pose", MFD_CLOEXEC | MFD_ALLOW_SEALING);
	if (fd < 0)
		return mc_err_set(err, "pose block: memfd_create: %s", strerror(errno));
	int rc = -1;
	if (ftruncate(fd, POSE_BLOCK_SIZE) != 0 || fcntl(fd, F_ADD_SEALS, F_SEAL_SHRINK | F_SEAL_GROW) != 0) {
		mc_err_set(err, "pose block: sizing and sealing: %s", strerror(errno));
		goto out;
	}
	void *p = mmap(NULL, POSE_BLOCK_SIZE, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
	if (p == MAP_FAILED) {
		mc_err_set(err, "pose block: mmap: %s", strerror(errno));
		goto out;
	}
	srv->pose = p; /* zero-filled: no pose yet */
	srv->pose->magic = POSE_BLOCK_MAGIC;
	srv->pose->version = POSE_BLOCK_VERSION;
	srv->pose->nslots = POSE_BLOCK_SLOTS;
	srv->pose->slot_bytes = POSE_BLOCK_SLOT_BYTES;
	srv->pose->max_joints = POSE_BLOCK_MAX_JOINTS;
	rc = seal_and_share(srv, fd, err);
out:
	close(fd);
	return rc;
}

void srv_pose_close(srv_server *srv)
{
	if (srv->pose)
		munmap(srv->pose, POSE_BLOCK_SIZE);
	srv->pose = NULL;
	if (srv->pose_fd >= 0)
		close(srv->pose_fd);
	srv->pose_fd = -1;
}

void srv_pose_write(srv_server *srv, const pending_frame *p)
{
	pose_block *b = srv->pose;
	if (!b)
		return;
	pose_block_slot *s = &b->slots[b->written % POSE_BLOCK_SLOTS];
	uint32_t lock = atomic_load_explicit(&b->seqlock, memory_order_relaxed);
	atomic_store_explicit(&b->seqlock, lock + 1, memory_order_relaxed);
	atomic_thread_fence(memory_order_release);
	s->seq = p->seq;
	s->capture_ns = p->capture_ns;
	s->publish_ns = p->publish_ns;
	s->skeleton_id = p->skeleton_id;
	s->njoints = (uint16_t)p->njoints;
	s->state = p->state;
	s->space = MC_SPACE_RIG;
	for (int j = 0; j < p->njoints; j++) {
		pose_block_joint *o = &s->joints[j];
		memcpy(o->position, p->j[j].pos, sizeof(o->position));
		memcpy(o->orientation, p->j[j].quat, sizeof(o->orientation));
		o->confidence = p->j[j].conf;
		o->reserved = 0;
	}
	b->written++;
	atomic_store_explicit(&b->seqlock, lock + 2, memory_order_release);
}

void srv_pose_wake(srv_server *srv)
{
	if (srv->pose)
		syscall(SYS_futex, &srv->pose->seqlock, FUTEX_WAKE, INT_MAX, NULL, NULL, 0);
}
