/* recorder: every skeleton of a take into a CSV file, nothing lost
 * silently.  "all" mode queues frames for us at the daemon; if we fall
 * behind anyway, the daemon says how many frames we missed and we write
 * that down too.
 *
 *   recorder OUT.csv [FRAMES] [SOCKET]
 *
 * Build against the installed library:  cc recorder.c $(pkg-config --cflags --libs mocap) */
#include <mocap.h>

#include <signal.h>
#include <stdio.h>
#include <stdlib.h>

static volatile sig_atomic_t stop;
static void on_signal(int sig) { (void)sig; stop = 1; }

int main(int argc, char **argv)
{
	if (argc < 2) {
		fprintf(stderr, "usage: recorder OUT.csv [FRAMES] [SOCKET]\n");
		return 2;
	}
	long frames = argc > 2 ? atol(argv[2]) : 0;
	mocap_client *c = mocap_connect(argc > 3 ? argv[3] : NULL, "recorder example");
	if (!c) {
		fprintf(stderr, "recorder: %s\n", mocap_errmsg());
		return 1;
	}
	mocap_skeleton_def *skel = malloc(sizeof(*skel));
	mocap_skeleton_frame *f = malloc(sizeof(*f));
	FILE *out = fopen(argv[1], "w");
	if (!out || mocap_get_skeleton(c, skel) != 0 || mocap_subscribe(c, MOCAP_ALL, MOCAP_SPACE_RIG, 1024) != 0) {
		fprintf(stderr, "recorder: %s\n", out ? mocap_errmsg() : "cannot open the output file");
		return 1;
	}
	signal(SIGINT, on_signal);
	fprintf(out, "seq,capture_ns,state,missed_before");
	for (int j = 0; j < skel->njoints; j++)
		fprintf(out, ",%s_x,%s_y,%s_z", skel->joints[j].name, skel->joints[j].name, skel->joints[j].name);
	fputc('\n', out);
	long n = 0, missed = 0;
	while (!stop && (frames <= 0 || n < frames)) {
		int r = mocap_read_frame(c, f, 500);
		if (r < 0) {
			fprintf(stderr, "recorder: %s\n", mocap_errmsg());
			break;
		}
		if (r == 0)
			continue;
		missed += (long)f->missed;
		fprintf(out, "%llu,%llu,%s,%llu", (unsigned long long)f->seq, (unsigned long long)f->capture_ns,
			mocap_track_state_name(f->state), (unsigned long long)f->missed);
		for (int j = 0; j < f->njoints; j++)
			fprintf(out, ",%.5f,%.5f,%.5f", f->joints[j].position[0], f->joints[j].position[1],
				f->joints[j].position[2]);
		fputc('\n', out);
		n++;
	}
	fclose(out);
	printf("recorder: %ld frames written, %ld missed\n", n, missed);
	free(f);
	free(skel);
	mocap_close(c);
	return 0;
}
