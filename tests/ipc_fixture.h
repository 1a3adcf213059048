/* What the IPC tests share: a chain skeleton for the server and frames
 * whose joint positions say which frame they are. */
#ifndef IPC_FIXTURE_H
#define IPC_FIXTURE_H

#include "server.h"
#include "test_util.h"

#include <string.h>

/* Joints j0..j(n-1), each the child of the one before, joint j at rest
 * 0.1 * j m along y from its parent. */
static inline void ipc_set_chain_def(srv_server *srv, int njoints)
{
	srv_skeleton_def def = {0};
	def.njoints = njoints;
	for (int j = 0; j < njoints; j++) {
		snprintf(def.name[j], sizeof(def.name[j]), "j%d", j);
		def.parent[j] = j - 1;
		def.rest_offset[j] = mc_v3(0, 0.1 * j, 0);
	}
	mc_err err;
	CHECK(srv_set_skeleton_def(srv, &def, &err) == 0);
}

/* Publishes frame `seq` (captured at seq * ns_per_seq), joint j at
 * position(seq, j), identity orientations, confidence 1.  srv_publish's
 * result. */
static inline int ipc_publish(srv_server *srv, uint64_t seq, int njoints, uint64_t ns_per_seq,
			      mc_vec3 (*position)(uint64_t seq, int j))
{
	mc_skeleton sk;
	memset(&sk, 0, sizeof(sk));
	sk.timestamp_ns = seq * ns_per_seq;
	sk.njoints = njoints;
	for (int j = 0; j < njoints; j++) {
		sk.joints[j].position = position(seq, j);
		sk.joints[j].orientation = mc_quat_identity();
		sk.joints[j].confidence = 1;
	}
	mc_err err;
	return srv_publish(srv, &sk, seq, &err);
}

#endif
