#include "grouper.h"

#include <string.h>

void mcd_grouper_init(mcd_grouper *g, int ncams, uint64_t tolerance_ns, uint64_t deadline_ns)
{
	memset(g, 0, sizeof(*g));
	g->ncams = ncams < MC_MAX_CAMERAS ? ncams : MC_MAX_CAMERAS;
	mcd_grouper_set_limits(g, tolerance_ns, deadline_ns);
}

void mcd_grouper_set_limits(mcd_grouper *g, uint64_t tolerance_ns, uint64_t deadline_ns)
{
	g->tolerance_ns = tolerance_ns;
	g->deadline_ns = deadline_ns;
}

static const mcd_frame_ref *head_of(const mcd_grouper *g, int c)
{
	return g->cam[c].count ? &g->cam[c].q[g->cam[c].head] : NULL;
}

static void drop_head(mcd_grouper *g, int c)
{
	g->cam[c].head = (g->cam[c].head + 1) % MCD_GROUP_QUEUE;
	g->cam[c].count--;
}

bool mcd_grouper_push(mcd_grouper *g, int cam, const mcd_frame_ref *f)
{
	if (cam < 0 || cam >= g->ncams)
		return false;
	if (g->emitted_any && f->timestamp_ns <= g->last_ts + g->tolerance_ns) {
		g->stats.late[cam]++;
		return false;
	}
	if (g->cam[cam].count == MCD_GROUP_QUEUE) {
		drop_head(g, cam);
		g->stats.overflow[cam]++;
	}
	int tail = (g->cam[cam].head + g->cam[cam].count) % MCD_GROUP_QUEUE;
	g->cam[cam].q[tail] = *f;
	g->cam[cam].count++;
	return true;
}

/* The camera whose oldest pending frame is the oldest of all, or -1. */
static int anchor_cam(const mcd_grouper *g)
{
	int best = -1;
	for (int c = 0; c < g->ncams; c++) {
		const mcd_frame_ref *h = head_of(g, c);
		if (h && (best < 0 || h->timestamp_ns < head_of(g, best)->timestamp_ns))
			best = c;
	}
	return best;
}

/* The members the group anchored at `anchor` would have now, and the
 * earliest arrival among them. */
static void gather(const mcd_grouper *g, int anchor, bool *has, uint64_t *first_arrival)
{
	uint64_t t0 = head_of(g, anchor)->timestamp_ns;
	*first_arrival = UINT64_MAX;
	for (int c = 0; c < g->ncams; c++) {
		const mcd_frame_ref *h = head_of(g, c);
		has[c] = h && h->timestamp_ns <= t0 + g->tolerance_ns;
		if (has[c] && h->arrival_ns < *first_arrival)
			*first_arrival = h->arrival_ns;
	}
}

bool mcd_grouper_pop(mcd_grouper *g, uint64_t now, uint32_t expect, mcd_group *out)
{
	int anchor = anchor_cam(g);
	if (anchor < 0)
		return false;
	bool has[MC_MAX_CAMERAS];
	uint64_t first_arrival;
	gather(g, anchor, has, &first_arrival);
	bool waiting = false; /* for an expected camera that may still deliver */
	for (int c = 0; c < g->ncams; c++)
		if (!has[c] && (expect & (1u << c)) && !head_of(g, c))
			waiting = true;
	if (waiting && now < first_arrival + g->deadline_ns)
		return false;

	memset(out, 0, sizeof(*out));
	out->timestamp_ns = head_of(g, anchor)->timestamp_ns;
	out->ready_ns = waiting ? first_arrival + g->deadline_ns : 0;
	for (int c = 0; c < g->ncams; c++) {
		if (has[c]) {
			out->has[c] = true;
			out->frame[c] = *head_of(g, c);
			if (!waiting && out->frame[c].arrival_ns > out->ready_ns)
				out->ready_ns = out->frame[c].arrival_ns;
			out->present++;
			drop_head(g, c);
		} else
			g->stats.missing[c]++;
	}
	if (out->ready_ns > now)
		out->ready_ns = now;
	g->stats.groups++;
	if (out->present == g->ncams)
		g->stats.complete++;
	else
		g->stats.partial++;
	g->emitted_any = true;
	g->last_ts = out->timestamp_ns;
	/* Drop what is now late: frames of this instant that lost the race
	 * (a second frame of one camera within tolerance). */
	for (int c = 0; c < g->ncams; c++)
		while (head_of(g, c) && head_of(g, c)->timestamp_ns <= g->last_ts + g->tolerance_ns) {
			drop_head(g, c);
			g->stats.late[c]++;
		}
	return true;
}

uint64_t mcd_grouper_due(const mcd_grouper *g)
{
	int anchor = anchor_cam(g);
	if (anchor < 0)
		return UINT64_MAX;
	bool has[MC_MAX_CAMERAS];
	uint64_t first_arrival;
	gather(g, anchor, has, &first_arrival);
	return first_arrival + g->deadline_ns;
}

int mcd_grouper_pending(const mcd_grouper *g)
{
	int n = 0;
	for (int c = 0; c < g->ncams; c++)
		n += g->cam[c].count;
	return n;
}
