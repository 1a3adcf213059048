#include "backoff.h"

static double wait_after(const mcd_backoff *b, unsigned failures)
{
	double w = b->initial_ms;
	for (unsigned i = 0; i < failures && w < b->max_ms; i++)
		w *= 2;
	return w < b->max_ms ? w : b->max_ms;
}

void mcd_backoff_init(mcd_backoff *b, double initial_ms, double max_ms)
{
	b->failures = 0;
	mcd_backoff_set_limits(b, initial_ms, max_ms);
}

void mcd_backoff_set_limits(mcd_backoff *b, double initial_ms, double max_ms)
{
	b->initial_ms = initial_ms > 0 ? initial_ms : 1;
	b->max_ms = max_ms >= b->initial_ms ? max_ms : b->initial_ms;
	b->next_ms = wait_after(b, b->failures);
}

double mcd_backoff_next(mcd_backoff *b)
{
	double w = wait_after(b, b->failures);
	b->failures++;
	b->next_ms = wait_after(b, b->failures);
	return w;
}

void mcd_backoff_reset(mcd_backoff *b)
{
	b->failures = 0;
	b->next_ms = b->initial_ms;
}
