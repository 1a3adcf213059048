/* Fan-out: skeletons from the daemon to subscribers.  The daemon's publish
 * thread puts each skeleton (and each new skeleton definition) into a
 * mailbox under the lock and wakes the server thread; the server thread
 * drains the mailbox, encodes each frame once per space asked for (rig, or
 * world through the head pose at its capture time) and hands the blob to
 * every subscriber's queue.  "all" subscribers that cannot take a frame, or
 * missed frames the daemon never published, get a gap. */
#include "server/internal.h"

#include <stdlib.h>

/* --- The daemon's side --- */

int srv_set_skeleton_def(srv_server *srv, const srv_skeleton_def *def, mc_err *err)
{
	if (def->njoints < 1 || def->njoints > MC_MAX_JOINTS)
		return mc_err_set(err, "skeleton definition: %d joints, expected 1..%d", def->njoints, MC_MAX_JOINTS);
	for (int j = 0; j < def->njoints; j++) {
		if (def->parent[j] < -1 || def->parent[j] >= j)
			return mc_err_set(err, "skeleton definition: joint %d (%s): parent %d must be -1 or an earlier joint",
					  j, def->name[j], def->parent[j]);
		if (!memchr(def->name[j], 0, MC_JOINT_NAME_MAX) || !def->name[j][0])
			return mc_err_set(err, "skeleton definition: joint %d: empty or unterminated name", j);
		if (!mc_v3_isfinite(def->rest_offset[j]))
			return mc_err_set(err, "skeleton definition: joint %d (%s): offset is not finite", j, def->name[j]);
	}
	pthread_mutex_lock(&srv->lock);
	srv->def = *def;
	srv->def_set = true;
	srv->def_changed = true;
	srv->def_at = srv->mb_count;
	srv->def_id++;
	pthread_mutex_unlock(&srv->lock);
	srv_wake(srv);
	return 0;
}

int srv_set_skeleton_def_from_model(srv_server *srv, const mc_model *model, mc_err *err)
{
	srv_skeleton_def *d = calloc(1, sizeof(*d));
	if (!d)
		return mc_err_set(err, "out of memory");
	d->njoints = model->njoints;
	d->rig_is_world = model->root_free;
	for (int j = 0; j < model->njoints && j < MC_MAX_JOINTS; j++) {
		srv_str_copy(d->name[j], sizeof(d->name[j]), model->joints[j].name);
		d->parent[j] = model->joints[j].parent;
		double s = model->bone_scale[j] > 0 ? model->bone_scale[j] : 1.0;
		d->rest_offset[j] = mc_v3_scale(model->joints[j].offset, s);
	}
	int rc = srv_set_skeleton_def(srv, d, err);
	free(d);
	return rc;
}

int srv_publish(srv_server *srv, const mc_skeleton *sk, uint64_t seq, mc_err *err)
{
	uint64_t t = mc_now_ns();
	int rc = 0;
	pthread_mutex_lock(&srv->lock);
	if (!srv->def_set) {
		rc = mc_err_set(err, "publish: no skeleton definition set (srv_set_skeleton_def)");
	} else if (sk->njoints != srv->def.njoints) {
		rc = mc_err_set(err, "publish: skeleton has %d joints, the definition %d", sk->njoints,
				srv->def.njoints);
	} else if (srv->mb_count == MAILBOX_LEN) {
		/* The server thread is starved; the frame is lost for every
		 * client, and "all" clients see it as a gap in seq. */
		srv->stats.mailbox_drops++;
		rc = mc_err_set(err, "publish: server thread is %d frames behind; frame %llu dropped", MAILBOX_LEN,
				(unsigned long long)seq);
	} else {
		pending_frame *p = &srv->mailbox[(srv->mb_head + srv->mb_count) % MAILBOX_LEN];
		srv->mb_count++;
		p->seq = seq;
		p->capture_ns = sk->timestamp_ns;
		p->publish_ns = t;
		p->skeleton_id = srv->def_id;
		p->state = (uint8_t)sk->state;
		p->njoints = sk->njoints;
		for (int j = 0; j < sk->njoints; j++) {
			const mc_skeleton_joint *sj = &sk->joints[j];
			p->j[j].pos[0] = sj->position.x;
			p->j[j].pos[1] = sj->position.y;
			p->j[j].pos[2] = sj->position.z;
			p->j[j].quat[0] = sj->orientation.w;
			p->j[j].quat[1] = sj->orientation.x;
			p->j[j].quat[2] = sj->orientation.y;
			p->j[j].quat[3] = sj->orientation.z;
			p->j[j].conf = sj->confidence;
		}
		srv_pose_write(srv, p);
		srv->stats.frames_published++;
	}
	pthread_mutex_unlock(&srv->lock);
	if (rc == 0) {
		srv_pose_wake(srv);
		srv_wake(srv);
	}
	return rc;
}

/* --- The server thread's side --- */

static void fill_frame_msg(mc_msg_frame *f, const pending_frame *p)
{
	f->seq = p->seq;
	f->capture_ns = p->capture_ns;
	f->publish_ns = p->publish_ns;
	f->skeleton_id = p->skeleton_id;
	f->njoints = (uint16_t)p->njoints;
	f->state = p->state;
	f->space = MC_SPACE_RIG;
	for (int j = 0; j < p->njoints; j++) {
		memcpy(f->joints[j].position, p->j[j].pos, sizeof(p->j[j].pos));
		memcpy(f->joints[j].orientation, p->j[j].quat, sizeof(p->j[j].quat));
		f->joints[j].confidence = p->j[j].conf;
	}
}

/* Moves every joint of a rig-space frame into the world (hp = world_from_rig). */
static void frame_to_world(mc_msg_frame *f, const srv_head_pose *hp)
{
	for (int j = 0; j < f->njoints; j++) {
		mc_wire_joint *jt = &f->joints[j];
		mc_vec3 p = mc_v3(jt->position[0], jt->position[1], jt->position[2]);
		mc_quat q = {jt->orientation[0], jt->orientation[1], jt->orientation[2], jt->orientation[3]};
		mc_pose_apply(hp, &p, &q);
		jt->position[0] = p.x;
		jt->position[1] = p.y;
		jt->position[2] = p.z;
		jt->orientation[0] = q.w;
		jt->orientation[1] = q.x;
		jt->orientation[2] = q.y;
		jt->orientation[3] = q.z;
	}
	f->space = MC_SPACE_WORLD;
}

/* Hands one frame to every subscriber. */
static void distribute_frame(srv_server *srv, const pending_frame *p, uint64_t *drops)
{
	uint64_t missed = 0;
	if (srv->expected_seq && p->seq > srv->expected_seq)
		missed = p->seq - srv->expected_seq;
	srv->expected_seq = p->seq + 1;

	bool any_world = false, any_rig = false;
	for (int i = 0; i < srv->nclients; i++) {
		client *c = srv->clients[i];
		if (c->dead || !c->mode)
			continue;
		if (c->space == MC_SPACE_WORLD)
			any_world = true;
		else
			any_rig = true;
	}
	proto_msg *m = srv_out_msg(srv, MC_MSG_FRAME, 0);
	fill_frame_msg(&m->u.frame, p);
	blob *rig = NULL, *world = NULL;
	if (any_rig || (any_world && !srv->def_rig_is_world))
		rig = srv_encode_blob(srv, m, true);
	if (any_world) {
		srv_head_pose hp;
		if (srv->def_rig_is_world) {
			m->u.frame.space = MC_SPACE_WORLD;
			world = srv_encode_blob(srv, m, true);
		} else if (mc_pose_at(srv->head_hist, srv->head_n, p->capture_ns, srv->cfg.head_pose_max_age_ns, &hp)) {
			frame_to_world(&m->u.frame, &hp);
			world = srv_encode_blob(srv, m, true);
		} else if (rig) {
			world = srv_blob_ref(rig); /* no head pose: sent in rig space, marked so */
		}
	}

	for (int i = 0; i < srv->nclients; i++) {
		client *c = srv->clients[i];
		if (c->dead || !c->mode)
			continue;
		blob *b = c->space == MC_SPACE_WORLD ? world : rig;
		if (!b)
			continue;
		if (c->mode == MC_SUB_LATEST) {
			srv_blob_unref(c->latest);
			c->latest = srv_blob_ref(b);
		} else {
			if (missed && !c->gap_count)
				c->gap_first = p->seq - missed;
			c->gap_count += missed;
			srv_queue_gap(srv, c);
			if (c->gap_count || c->qframes >= (int)c->queue_len || !srv_q_push(c, b)) {
				if (!c->gap_count)
					c->gap_first = p->seq;
				c->gap_count++;
				(*drops)++;
			}
		}
		srv_client_flush(srv, c);
	}
	srv_blob_unref(rig);
	srv_blob_unref(world);
}

void srv_send_definition(srv_server *srv, client *c)
{
	if (srv->def_blob)
		srv_client_send(srv, c, srv->def_blob);
}

static void install_definition(srv_server *srv, const srv_skeleton_def *d, uint32_t id)
{
	proto_msg *m = srv_out_msg(srv, MC_MSG_SKELETON, 0);
	mc_msg_skeleton *s = &m->u.skeleton;
	s->skeleton_id = id;
	s->njoints = (uint16_t)d->njoints;
	s->rig_is_world = d->rig_is_world;
	for (int j = 0; j < d->njoints; j++) {
		s->joints[j].parent = d->parent[j];
		s->joints[j].offset[0] = d->rest_offset[j].x;
		s->joints[j].offset[1] = d->rest_offset[j].y;
		s->joints[j].offset[2] = d->rest_offset[j].z;
		srv_str_copy(s->joints[j].name, sizeof(s->joints[j].name), d->name[j]);
	}
	blob *b = srv_encode_blob(srv, m, false);
	if (!b)
		return;
	srv_blob_unref(srv->def_blob);
	srv->def_blob = b;
	srv->def_rig_is_world = d->rig_is_world;
	for (int i = 0; i < srv->nclients; i++)
		if (!srv->clients[i]->dead && srv->clients[i]->mode)
			srv_send_definition(srv, srv->clients[i]);
}

void srv_drain_mailbox(srv_server *srv)
{
	pthread_mutex_lock(&srv->lock);
	int n = srv->mb_count;
	for (int i = 0; i < n; i++)
		srv->drained[i] = srv->mailbox[(srv->mb_head + i) % MAILBOX_LEN];
	srv->mb_head = (srv->mb_head + n) % MAILBOX_LEN;
	srv->mb_count = 0;
	bool changed = srv->def_changed;
	uint32_t def_id = srv->def_id;
	int def_at = srv->def_at;
	if (changed)
		srv->def_copy = srv->def;
	srv->def_changed = false;
	pthread_mutex_unlock(&srv->lock);

	uint64_t drops = 0;
	for (int i = 0; i <= n; i++) {
		if (changed && i == def_at)
			install_definition(srv, &srv->def_copy, def_id);
		if (i < n)
			distribute_frame(srv, &srv->drained[i], &drops);
	}
	if (drops) {
		pthread_mutex_lock(&srv->lock);
		srv->stats.client_drops += drops;
		pthread_mutex_unlock(&srv->lock);
	}
}
