/* mc_view_agreement: do a frame set's keypoints agree across cameras?  For
 * footage without ground truth (issue 36: real footage is judged by eye and
 * by this): each keypoint of a joint that at least three other cameras also
 * report is checked against the point triangulated from those others,
 * reprojected into its own camera.  It agrees when it lies within
 * px_at_640 pixels scaled to its image (px_at_640 * max(width, height) /
 * 640).  A detector that puts a joint on a window in one view, or on the
 * bystander, disagrees; one that reports the same wrong limb in every view
 * does not (sides are judged by eye). */
#ifndef MC_VIEW_AGREEMENT_H
#define MC_VIEW_AGREEMENT_H

#include "geom/mc_rig.h"
#include "track/mc_tracker.h"

typedef struct {
	long checked; /* keypoints that had three other views of their joint */
	long agreed;  /* of those, within the bound */
} mc_view_agreement;

/* Adds one frame set's keypoints (cam: rig camera index, joint: any joint
 * numbering shared by the cameras; those below min_conf are ignored). */
void mc_view_agreement_add(mc_view_agreement *a, const mc_rig *rig, const mc_keypoint *kp, int nkp, double min_conf,
			   double px_at_640);

#endif
