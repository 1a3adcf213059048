/* Inputs to the tracker: 2D keypoints and VR head poses.  They are sent one
 * way, without waiting for an answer; a refusal by the daemon arrives as an
 * unsolicited ERROR and is reported by the next send. */
#include "client/internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The refusal of an earlier unacknowledged message, if any (lock held). */
static int take_async_error(mocap_client *c)
{
	if (c->dead)
		return mcl_dead_error(c);
	if (!c->async_code)
		return 0;
	int code = mcl_set_err(c->async_code, "%s", c->async_msg);
	c->async_code = 0;
	return code;
}

/* Sends an unacknowledged message; reports an earlier refusal first. */
static int send_oneway(mocap_client *c, proto_msg *m)
{
	/* Read what has arrived, so that a refusal is seen promptly. */
	pthread_mutex_lock(&c->lock);
	if (!c->reading)
		mcl_wait_step(c, 0);
	int rc = take_async_error(c);
	mcl_update_event(c);
	pthread_mutex_unlock(&c->lock);
	if (rc)
		return rc;
	m->h.request_id = mcl_next_id(c);
	return mcl_send_msg(c, m, mcl_deadline_after(c->timeout_ms));
}

int mocap_send_keypoints(mocap_client *c, uint64_t capture_ns, int camera, const mocap_keypoint *kp, int n)
{
	if (n < 0 || n > MOCAP_MAX_KEYPOINTS)
		return mcl_set_err(MOCAP_E_ARG, "keypoints: %d in one batch, at most %d", n, MOCAP_MAX_KEYPOINTS);
	if (camera < 0 || camera > 65535)
		return mcl_set_err(MOCAP_E_ARG, "keypoints: camera %d out of range", camera);
	proto_msg *m = mcl_new_msg(MC_MSG_KEYPOINTS);
	if (!m)
		return MOCAP_E_SYSTEM;
	m->u.keypoints.capture_ns = capture_ns;
	m->u.keypoints.camera = (uint16_t)camera;
	m->u.keypoints.count = (uint16_t)n;
	int rc = 0;
	for (int i = 0; i < n && rc == 0; i++) {
		if (kp[i].joint < 0 || kp[i].joint > 65535)
			rc = mcl_set_err(MOCAP_E_ARG, "keypoints: keypoint %d: joint %d out of range", i, kp[i].joint);
		else if (!isfinite(kp[i].u) || !isfinite(kp[i].v) || !(kp[i].confidence >= 0 && kp[i].confidence <= 1))
			rc = mcl_set_err(MOCAP_E_ARG, "keypoints: keypoint %d: u, v must be finite and confidence in 0..1", i);
		m->u.keypoints.kp[i].joint = (uint16_t)kp[i].joint;
		m->u.keypoints.kp[i].u = kp[i].u;
		m->u.keypoints.kp[i].v = kp[i].v;
		m->u.keypoints.kp[i].confidence = kp[i].confidence;
	}
	if (rc == 0)
		rc = send_oneway(c, m);
	free(m);
	return rc;
}

int mocap_send_head_pose(mocap_client *c, uint64_t timestamp_ns, const double position[3],
			 const double orientation_wxyz[4])
{
	double n2 = 0;
	for (int i = 0; i < 4; i++) {
		n2 += orientation_wxyz[i] * orientation_wxyz[i];
		if (!isfinite(orientation_wxyz[i]) || (i < 3 && !isfinite(position[i])))
			return mcl_set_err(MOCAP_E_ARG, "head pose: not a finite number");
	}
	if (fabs(sqrt(n2) - 1.0) > 1e-3)
		return mcl_set_err(MOCAP_E_ARG, "head pose: orientation is not a unit quaternion (w, x, y, z): length %g",
				   sqrt(n2));
	proto_msg *m = mcl_new_msg(MC_MSG_HEAD_POSE);
	if (!m)
		return MOCAP_E_SYSTEM;
	m->u.head_pose.timestamp_ns = timestamp_ns;
	memcpy(m->u.head_pose.position, position, sizeof(m->u.head_pose.position));
	memcpy(m->u.head_pose.orientation, orientation_wxyz, sizeof(m->u.head_pose.orientation));
	int rc = send_oneway(c, m);
	free(m);
	return rc;
}
