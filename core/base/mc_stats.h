/* Small statistics for benchmarks and status reports: sorting samples and
 * reading percentiles off them. */
#ifndef MC_STATS_H
#define MC_STATS_H

#include <stddef.h>

/* Sorts n doubles ascending. */
void mc_stats_sort(double *v, size_t n);

/* The median of n samples, sorting v in place: the middle one, or the
 * mean of the middle two; 0 when n == 0. */
double mc_stats_median(double *v, size_t n);

/* The p-th percentile (p in [0, 100]) of n sorted samples by the nearest-rank
 * method; 0 when n == 0. */
double mc_stats_percentile(const double *sorted, size_t n, double p);

#endif
