/* vr_latest: what a VR runtime does each display frame: take the newest
 * skeleton (never a queue of old ones) and use it.  Runs a 90 Hz loop for
 * five seconds and prints the age of the pose it would render with.
 *
 *   vr_latest [SOCKET]          (default: $MOCAP_SOCKET or /run/mocapd/mocapd.sock)
 *
 * Build against the installed library:  cc vr_latest.c $(pkg-config --cflags --libs mocap) */
#include <mocap.h>

#include <stdio.h>
#include <stdlib.h>
#include <time.h>

int main(int argc, char **argv)
{
	setvbuf(stdout, NULL, _IOLBF, 0);
	mocap_client *c = mocap_connect(argc > 1 ? argv[1] : NULL, "vr_latest example");
	if (!c) {
		fprintf(stderr, "vr_latest: %s\n", mocap_errmsg());
		return 1;
	}
	if (mocap_subscribe(c, MOCAP_LATEST, MOCAP_SPACE_RIG, 0) != 0) {
		fprintf(stderr, "vr_latest: %s\n", mocap_errmsg());
		mocap_close(c);
		return 1;
	}
	mocap_skeleton_frame *pose = malloc(sizeof(*pose)); /* about 8 KB: not on small stacks */
	int have_pose = 0;
	for (int tick = 0; tick < 5 * 90; tick++) {
		/* Non-blocking: the newest pose if one came since the last tick. */
		int r = mocap_read_frame(c, pose, 0);
		if (r < 0) {
			fprintf(stderr, "vr_latest: %s\n", mocap_errmsg());
			break;
		}
		have_pose |= r == 1;
		if (have_pose && tick % 45 == 0)
			printf("tick %3d: pose %llu (%s), %.2f ms old, root at (%.3f, %.3f, %.3f)\n", tick,
			       (unsigned long long)pose->seq, mocap_track_state_name(pose->state),
			       (double)(mocap_now_ns() - pose->capture_ns) * 1e-6, pose->joints[0].position[0],
			       pose->joints[0].position[1], pose->joints[0].position[2]);
		struct timespec ts = {0, 11111111}; /* "render" */
		nanosleep(&ts, NULL);
	}
	free(pose);
	mocap_close(c);
	return 0;
}
