/* Condition variables on CLOCK_MONOTONIC: the one place that sets the
 * clock attribute, so that a wall-clock step (NTP, suspend) never makes a
 * timed wait return early or hang. */
#ifndef MC_THREAD_H
#define MC_THREAD_H

#include <pthread.h>
#include <stdint.h>

#include "base/mc_time.h"

/* pthread_cond_init with CLOCK_MONOTONIC; returns pthread_cond_init's code. */
static inline int mc_cond_init_monotonic(pthread_cond_t *cond)
{
	pthread_condattr_t ca;
	pthread_condattr_init(&ca);
	pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
	int rc = pthread_cond_init(cond, &ca);
	pthread_condattr_destroy(&ca);
	return rc;
}

/* The absolute deadline `timeout_ns` from now, for pthread_cond_timedwait
 * on a condition made by mc_cond_init_monotonic. */
static inline struct timespec mc_cond_deadline(uint64_t timeout_ns)
{
	return mc_ns_timespec(mc_now_ns() + timeout_ns);
}

#endif
