#include "base/mc_stats.h"

#include <math.h>
#include <stdlib.h>

static int cmp_double(const void *a, const void *b)
{
	double x = *(const double *)a, y = *(const double *)b;
	return (x > y) - (x < y);
}

void mc_stats_sort(double *v, size_t n)
{
	if (n > 1)
		qsort(v, n, sizeof v[0], cmp_double);
}

double mc_stats_percentile(const double *sorted, size_t n, double p)
{
	if (n == 0)
		return 0;
	/* Nearest rank: the smallest sample with at least p% of them at or below it. */
	long i = (long)ceil(p / 100.0 * (double)n) - 1;
	if (i < 0)
		i = 0;
	if (i >= (long)n)
		i = (long)n - 1;
	return sorted[i];
}

double mc_stats_median(double *v, size_t n)
{
	if (n == 0)
		return 0;
	mc_stats_sort(v, n);
	return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

void mc_stats_window_add(double *v, int cap, int *n, int *next, double x)
{
	v[*next] = x;
	*next = (*next + 1) % cap;
	if (*n < cap)
		(*n)++;
}
