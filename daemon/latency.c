/* latency: a ring of the newest stage times, read as percentiles. */
#include "latency.h"

#include "base/mc_stats.h"
#include "base/mc_time.h"

#include <stdlib.h>
#include <string.h>

/* b - a in ms; 0 when a stamp is missing or out of order (a clock step,
 * or a stage the set skipped). */
static double span_ms(uint64_t a, uint64_t b)
{
	return a && b > a ? (double)(b - a) / (double)MC_NS_PER_MS : 0.0;
}

void mcd_latency_add(mcd_latency *l, const mcd_output *o, uint64_t publish_ns)
{
	/* A set without a ready stamp (a test's hand-made output) goes
	 * straight from capture to tracking. */
	uint64_t ready = o->ready_ns ? o->ready_ns : o->timestamp_ns;
	uint64_t start = o->track_start_ns ? o->track_start_ns : ready;
	uint64_t decoded = o->decoded_ns ? o->decoded_ns : start;
	uint64_t end = o->track_end_ns ? o->track_end_ns : decoded;
	double v[SRV_LAT_NSTAGES] = {
		[SRV_LAT_READY] = span_ms(o->timestamp_ns, ready), [SRV_LAT_WAIT] = span_ms(ready, start),
		[SRV_LAT_DECODE] = span_ms(start, decoded),        [SRV_LAT_TRACK] = span_ms(decoded, end),
		[SRV_LAT_PUBLISH] = span_ms(end, publish_ns),      [SRV_LAT_TOTAL] = span_ms(o->timestamp_ns, publish_ns),
	};
	for (int s = 0; s < SRV_LAT_NSTAGES; s++)
		l->ms[s][l->next] = v[s];
	l->next = (l->next + 1) % MCD_LATENCY_WINDOW;
	if (l->n < MCD_LATENCY_WINDOW)
		l->n++;
}

void mcd_latency_summary(const mcd_latency *l, srv_latency_status *out)
{
	out->window = (uint32_t)l->n;
	double *sorted = malloc(sizeof(double) * MCD_LATENCY_WINDOW);
	for (int s = 0; s < SRV_LAT_NSTAGES; s++) {
		memset(&out->stage[s], 0, sizeof(out->stage[s]));
		if (!sorted || !l->n)
			continue;
		memcpy(sorted, l->ms[s], sizeof(double) * (size_t)l->n); /* the first n slots are the filled ones */
		mc_stats_sort(sorted, (size_t)l->n);
		out->stage[s].p50 = mc_stats_percentile(sorted, (size_t)l->n, 50);
		out->stage[s].p99 = mc_stats_percentile(sorted, (size_t)l->n, 99);
		out->stage[s].max = sorted[l->n - 1];
	}
	free(sorted);
}
