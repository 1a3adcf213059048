/* frame_size: a camera's frame size against its rig camera's calibrated
 * size (issue 31 item 2).
 *
 * The rig file's intrinsics hold at the size the camera was calibrated at.
 * Frames of another size are either a whole-number scale of it with the
 * same aspect ratio (2x, 3x ... larger, or 2x ... smaller: a binned or
 * full-resolution mode of the same sensor), which the daemon handles, or
 * a mismatch that would track nonsense: refused.
 *
 * Handled how: the tracker resamples every view to its working resolution
 * (mc_trk_load_views), so the colour term needs nothing; the detector's
 * keypoints are in frame pixels and are scaled to the rig camera's pixels
 * (mcd_frame_to_rig_scale) before the tracker takes them.
 *
 * Checked when: by `mocapd --check` from a camera's `width` and `height`
 * keys, which every hardware driver (v4l2, usb, aravis, libcamera,
 * openni2) and sim read as the delivered size; drivers that take the size
 * from their input (files, take) are checked at the first frame, where the
 * tracking thread drops the views of a mismatched camera and says why. */
#ifndef MCD_FRAME_SIZE_H
#define MCD_FRAME_SIZE_H

#include "config.h"
#include "base/mc_error.h"
#include "geom/mc_rig.h"

#include <stddef.h>

/* 1: the frame is the rig camera's size times a whole number, or divided
 * by one, on both axes alike; *to_rig then is the factor that takes frame
 * pixels to rig pixels (1 when equal).  0: a mismatch. */
int mcd_frame_to_rig_scale(int fw, int fh, int rw, int rh, double *to_rig);

/* A frame pixel coordinate in rig camera pixels (the centre of the
 * top-left pixel is 0, as in mc_camera.h), for a factor from
 * mcd_frame_to_rig_scale. */
double mcd_frame_to_rig_coord(double u, double to_rig);

/* Explains a mismatch of fw x fh frames against rig camera `rc` (of the
 * rig file rig_path) and what to do about it, into buf. */
void mcd_frame_size_explain(int fw, int fh, const mc_camera *rc, const char *rig_path, char *buf, size_t cap);

/* --check: each tracked camera whose section sets width and height against
 * its rig camera (cam_to_rig: configured camera -> rig camera).  0, or -1
 * with every mismatch in err, each naming the file, line and keys. */
int mcd_frame_size_check(const mcd_config *cfg, const mc_rig *rig, const int *cam_to_rig, mc_err *err);

#endif
