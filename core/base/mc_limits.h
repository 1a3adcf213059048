/* Limits shared by every layer.  The wire protocol (ipc/proto.h) and the
 * client library (ipc/mocap.h) have limits of their own, because they are
 * the contract with clients; _Static_asserts there tie them to these. */
#ifndef MC_LIMITS_H
#define MC_LIMITS_H

/* Cameras in one rig, and so in one frame set, status report and pipeline. */
#define MC_MAX_CAMERAS 8

#endif
