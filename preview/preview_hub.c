/* preview_hub: newest-event slots and the readers that drain them
 * (preview_hub.h). */
#include "preview_hub.h"

#include "base/mc_time.h"

#include <pthread.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef struct {
	char *text;       /* the whole SSE event, or NULL */
	uint64_t version; /* hub-wide counter at the last post */
} hub_slot;

struct preview_hub {
	pthread_mutex_t lock;
	pthread_cond_t changed;
	hub_slot slot[HUB_MAX_SLOTS];
	uint64_t version;
	int readers;
	bool stopped, log_pages;
};

struct hub_reader {
	preview_hub *hub;
	uint64_t seen[HUB_MAX_SLOTS];
	char *pending; /* the event being sent, and how much of it went */
	size_t len, off;
};

preview_hub *hub_new(bool log_pages)
{
	preview_hub *h = calloc(1, sizeof(*h));
	if (!h)
		return NULL;
	h->log_pages = log_pages;
	pthread_mutex_init(&h->lock, NULL);
	pthread_condattr_t a;
	pthread_condattr_init(&a);
	pthread_condattr_setclock(&a, CLOCK_MONOTONIC);
	pthread_cond_init(&h->changed, &a);
	pthread_condattr_destroy(&a);
	return h;
}

void hub_stop(preview_hub *h)
{
	pthread_mutex_lock(&h->lock);
	h->stopped = true;
	pthread_cond_broadcast(&h->changed);
	pthread_mutex_unlock(&h->lock);
}

void hub_free(preview_hub *h)
{
	if (!h)
		return;
	for (int i = 0; i < HUB_MAX_SLOTS; i++)
		free(h->slot[i].text);
	pthread_cond_destroy(&h->changed);
	pthread_mutex_destroy(&h->lock);
	free(h);
}

int hub_post(preview_hub *h, int slot, const char *name, const char *data)
{
	if (slot < 0 || slot >= HUB_MAX_SLOTS)
		return -1;
	size_t n = strlen(name) + strlen(data) + 20;
	char *text = malloc(n);
	if (!text)
		return -1;
	snprintf(text, n, "event: %s\ndata: %s\n\n", name, data);
	pthread_mutex_lock(&h->lock);
	free(h->slot[slot].text);
	h->slot[slot].text = text;
	h->slot[slot].version = ++h->version;
	pthread_cond_broadcast(&h->changed);
	pthread_mutex_unlock(&h->lock);
	return 0;
}

int hub_readers(preview_hub *h)
{
	pthread_mutex_lock(&h->lock);
	int n = h->readers;
	pthread_mutex_unlock(&h->lock);
	return n;
}

hub_reader *hub_reader_new(preview_hub *h)
{
	hub_reader *r = calloc(1, sizeof(*r));
	if (!r)
		return NULL;
	r->hub = h;
	pthread_mutex_lock(&h->lock);
	int n = ++h->readers;
	pthread_mutex_unlock(&h->lock);
	if (h->log_pages)
		printf("mocap-preview: a page opened (%d open)\n", n);
	/* A page asks for its first events at once: "retry" tells the browser
	 * how soon to reconnect if the stream breaks. */
	r->pending = strdup("retry: 1000\n\n");
	r->len = r->pending ? strlen(r->pending) : 0;
	return r;
}

void hub_reader_free(hub_reader *r)
{
	if (!r)
		return;
	pthread_mutex_lock(&r->hub->lock);
	int n = --r->hub->readers;
	pthread_mutex_unlock(&r->hub->lock);
	if (r->hub->log_pages)
		printf("mocap-preview: a page closed (%d open)\n", n);
	free(r->pending);
	free(r);
}

/* The oldest slot this reader has not seen, or -1.  Under the lock. */
static int next_slot(const hub_reader *r)
{
	int best = -1;
	for (int i = 0; i < HUB_MAX_SLOTS; i++) {
		const hub_slot *s = &r->hub->slot[i];
		if (s->text && s->version > r->seen[i] && (best < 0 || s->version < r->hub->slot[best].version))
			best = i;
	}
	return best;
}

/* Takes the next event (or a keep-alive) into r->pending; false when the
 * hub stopped. */
static bool take_event(hub_reader *r, int keepalive_ms)
{
	preview_hub *h = r->hub;
	struct timespec until = mc_ns_timespec(mc_now_ns() + (uint64_t)keepalive_ms * MC_NS_PER_MS);
	pthread_mutex_lock(&h->lock);
	int slot;
	int rc = 0;
	while (!h->stopped && (slot = next_slot(r)) < 0 && rc == 0)
		rc = pthread_cond_timedwait(&h->changed, &h->lock, &until);
	bool ok = !h->stopped;
	if (ok) {
		slot = next_slot(r);
		free(r->pending);
		if (slot >= 0) {
			r->pending = strdup(h->slot[slot].text);
			r->seen[slot] = h->slot[slot].version;
		} else
			r->pending = strdup(": keep-alive\n\n");
		r->len = r->pending ? strlen(r->pending) : 0;
		r->off = 0;
	}
	pthread_mutex_unlock(&h->lock);
	return ok && r->pending;
}

long hub_reader_read(hub_reader *r, char *buf, size_t cap, int keepalive_ms)
{
	if (r->off >= r->len && !take_event(r, keepalive_ms))
		return -1;
	size_t n = r->len - r->off < cap ? r->len - r->off : cap;
	memcpy(buf, r->pending + r->off, n);
	r->off += n;
	return (long)n;
}
