/* cl_cache: a folder for PoCL's kernel cache before OpenCL is touched.
 *
 * PoCL (the CPU OpenCL platform mocapd runs on without a GPU) compiles
 * kernels into $POCL_CACHE_DIR, else $XDG_CACHE_HOME/pocl, else
 * $HOME/.cache/pocl; when none of these can be created it reports no
 * device at all, and the tracker fails with "OpenCL: no device on any
 * platform".  mocapd.service sets POCL_CACHE_DIR; a hand start as the
 * `mocapd` user (home /nonexistent) did not (issue 31 item 3).  So when
 * POCL_CACHE_DIR is unset and neither XDG_CACHE_HOME nor HOME gives a
 * writable folder, mocapd sets it to the first that works of
 * /var/cache/mocapd/pocl and $TMPDIR (or /tmp)/mocapd-pocl-UID. */
#ifndef MCD_CL_CACHE_H
#define MCD_CL_CACHE_H

#include <stddef.h>

/* Sets POCL_CACHE_DIR when needed (see above).  Writes what was done into
 * note (empty when PoCL finds its own folder) and returns 0, or -1 with
 * note saying what is missing when no folder could be found. */
int mcd_cl_cache_setup(char *note, size_t cap);

#endif
