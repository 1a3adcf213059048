/* The one clock helper of the tree: CLOCK_MONOTONIC nanoseconds (the time
 * base of every frame, skeleton and message, docs/CONVENTIONS.md "Conventions"),
 * CLOCK_REALTIME for recordings, and absolute sleeps and deadlines.
 *
 * Header-only (static inline) so that driver plugins, which do not link
 * the core library, use the same functions. */
#ifndef MC_TIME_H
#define MC_TIME_H

#include <errno.h>
#include <stdint.h>
#include <time.h>

#define MC_NS_PER_S 1000000000ull
#define MC_NS_PER_MS 1000000ull

static inline uint64_t mc_timespec_ns(const struct timespec *ts)
{
	return (uint64_t)ts->tv_sec * MC_NS_PER_S + (uint64_t)ts->tv_nsec;
}

static inline struct timespec mc_ns_timespec(uint64_t ns)
{
	struct timespec ts = {(time_t)(ns / MC_NS_PER_S), (long)(ns % MC_NS_PER_S)};
	return ts;
}

/* CLOCK_MONOTONIC now, in nanoseconds. */
static inline uint64_t mc_now_ns(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return mc_timespec_ns(&ts);
}

/* CLOCK_REALTIME now, in nanoseconds (recordings carry it beside monotonic). */
static inline uint64_t mc_realtime_ns(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_REALTIME, &ts);
	return mc_timespec_ns(&ts);
}

/* Milliseconds from t0_ns (monotonic) to now. */
static inline double mc_ms_since(uint64_t t0_ns)
{
	return (double)(mc_now_ns() - t0_ns) / 1e6;
}

/* Sleeps until CLOCK_MONOTONIC reaches t_ns, on through signals. */
static inline void mc_sleep_until_ns(uint64_t t_ns)
{
	struct timespec ts = mc_ns_timespec(t_ns);
	while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL) == EINTR)
		;
}

#endif
