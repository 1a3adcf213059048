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

/* A window over the last cap samples, kept in a ring: v[cap] holds *n of
 * them (at most cap), the next written at *next.  Adds x, dropping the
 * oldest once full. */
void mc_stats_window_add(double *v, int cap, int *n, int *next, double x);

#endif
