/* backoff: exponential delays between attempts to reopen a camera.
 *
 * The first retry waits initial_ms; every further failure doubles the wait,
 * up to max_ms.  A success (the camera delivered a good frame) resets it. */
#ifndef MCD_BACKOFF_H
#define MCD_BACKOFF_H

typedef struct {
	double initial_ms, max_ms;
	double next_ms;     /* the wait mcd_backoff_next will return */
	unsigned failures;  /* since the last reset */
} mcd_backoff;

void mcd_backoff_init(mcd_backoff *b, double initial_ms, double max_ms);
/* Changes the limits (config reload), keeping the failure count. */
void mcd_backoff_set_limits(mcd_backoff *b, double initial_ms, double max_ms);
/* The wait before the next attempt, in ms; counts one failure. */
double mcd_backoff_next(mcd_backoff *b);
void mcd_backoff_reset(mcd_backoff *b);

#endif
