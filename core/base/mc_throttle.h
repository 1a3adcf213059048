/* Log throttling for problems that can repeat at the frame rate (a broken
 * camera, a late frame): the first few occurrences, then every power of
 * two, so the log shows both the start and the persistence of a problem
 * without flooding the journal. */
#ifndef MC_THROTTLE_H
#define MC_THROTTLE_H

#include <stdbool.h>
#include <stdint.h>

/* n: how many times the problem has occurred so far, counting this one (>= 1). */
static inline bool mc_throttle_should_log(uint64_t n)
{
	return n <= 4 || (n & (n - 1)) == 0;
}

#endif
