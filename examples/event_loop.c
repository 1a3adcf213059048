/* event_loop: libmocap inside an application's own poll() loop, next to
 * other descriptors (here: standard input; type "s" for the daemon's
 * status, "q" to quit).  mocap_fd() becomes readable when a frame waits.
 *
 *   event_loop [SOCKET]
 *
 * Build against the installed library:  cc event_loop.c $(pkg-config --cflags --libs mocap) */
#include <mocap.h>

#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

int main(int argc, char **argv)
{
	mocap_client *c = mocap_connect(argc > 1 ? argv[1] : NULL, "event_loop example");
	if (!c || mocap_subscribe(c, MOCAP_LATEST, MOCAP_SPACE_RIG, 0) != 0) {
		fprintf(stderr, "event_loop: %s\n", mocap_errmsg());
		return 1;
	}
	mocap_skeleton_frame *f = malloc(sizeof(*f));
	unsigned long frames = 0;
	for (int running = 1; running;) {
		struct pollfd p[2] = {{.fd = mocap_fd(c), .events = POLLIN}, {.fd = STDIN_FILENO, .events = POLLIN}};
		if (poll(p, 2, 1000) < 0)
			break;
		if (p[0].revents) {
			int r;
			while ((r = mocap_read_frame(c, f, 0)) == 1) /* never blocks here */
				frames++;
			if (r < 0) {
				fprintf(stderr, "event_loop: %s\n", mocap_errmsg());
				break;
			}
		}
		if (p[1].revents) {
			char line[64];
			ssize_t n = read(STDIN_FILENO, line, sizeof(line));
			if (n <= 0 || line[0] == 'q')
				running = 0;
			else if (line[0] == 's') {
				mocap_daemon_status st;
				if (mocap_get_status(c, &st) == 0)
					printf("tracker %s, %.1f fps, %d clients; %lu frames here\n",
					       mocap_track_state_name(st.tracker_state), st.publish_fps, st.clients, frames);
				else
					fprintf(stderr, "event_loop: %s\n", mocap_errmsg());
			}
		}
	}
	free(f);
	mocap_close(c);
	return 0;
}
