/* Thread helpers.  Condition variables on CLOCK_MONOTONIC: the one place
 * that sets the clock attribute, so that a wall-clock step (NTP, suspend)
 * never makes a timed wait return early or hang.  And a thread's own name
 * and CPU priority. */
#ifndef MC_THREAD_H
#define MC_THREAD_H

#include <errno.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

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

/* Names the calling thread (printf format), cut to the kernel's 15
 * characters: `top -H`, `ps -L`, perf and gdb show it. */
static inline void mc_thread_set_name(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static inline void mc_thread_set_name(const char *fmt, ...)
{
	char name[16];
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(name, sizeof(name), fmt, ap);
	va_end(ap);
	pthread_setname_np(pthread_self(), name);
}

/* Lowers the calling thread's CPU priority by `by` nice steps (at most to
 * 19).  Linux keeps the nice value per thread, and threads created
 * afterwards from this one inherit it; raising it needs no privilege.
 * Returns the thread's new nice value, or -1 with errno set. */
static inline int mc_thread_lower_priority(int by)
{
	id_t tid = (id_t)syscall(SYS_gettid);
	errno = 0;
	int now = getpriority(PRIO_PROCESS, tid);
	if (now == -1 && errno)
		return -1;
	int want = now + (by > 0 ? by : 0);
	if (want > 19)
		want = 19;
	return setpriority(PRIO_PROCESS, tid, want) == 0 ? want : -1;
}

#endif
