/* preview_link: mocap-preview's side of mocapd.  Connects (and connects
 * again after the daemon restarted or went away, saying so once), follows
 * the newest skeleton, asks for the status once a second, and while a page
 * is open takes each camera's newest frame from its ring at a reduced
 * rate, draws the overlay and posts it to the hub. */
#ifndef PREVIEW_LINK_H
#define PREVIEW_LINK_H

#include "body/mc_model.h"
#include "preview_hub.h"

#include <signal.h>
#include <stdatomic.h>
#include <stdbool.h>

typedef struct {
	const char *socket;    /* NULL: mocap_default_socket() */
	const mc_model *model; /* for the Gaussians' outlines; NULL: joints only */
	double rate;           /* camera views per second and camera */
	int width;             /* their largest width, pixels */
	int quality;           /* JPEG quality */
	bool verbose;
	preview_hub *hub;
	volatile sig_atomic_t *stop;
	atomic_int *status_now; /* set by a state change: send the status at once */
} link_config;

/* Runs until *stop. */
void link_run(const link_config *cfg);

/* The hub's slots. */
#define SLOT_STATUS 0
#define SLOT_SKELETON 1
#define SLOT_FRAME0 2

#endif
