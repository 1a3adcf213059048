/* preview_hub: the Server-Sent Events hub of mocap-preview.
 *
 * The daemon side (one thread) posts events into named slots: "status",
 * "skeleton", and one "frame" slot per camera.  A slot keeps only its
 * newest event: a page that cannot keep up skips to the newest, it never
 * queues (and never slows the daemon side).  Each open page is an
 * hub_reader that the HTTP server drains from its own thread; it blocks
 * until a slot changed, or sends a keep-alive comment after a while so
 * that a closed page is noticed. */
#ifndef PREVIEW_HUB_H
#define PREVIEW_HUB_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define HUB_MAX_SLOTS 24 /* status, skeleton, and up to 16 cameras, with room */

typedef struct preview_hub preview_hub;
typedef struct hub_reader hub_reader;

/* log_pages: say on stdout when a page opens or closes its stream. */
preview_hub *hub_new(bool log_pages);
/* Wakes every reader (they end their streams); hub_free after the HTTP
 * server stopped. */
void hub_stop(preview_hub *h);
void hub_free(preview_hub *h);

/* Replaces slot `slot`'s event: "event: NAME\ndata: DATA\n\n".  data is
 * one line (JSON without newlines).  Returns 0 or -1 (out of memory). */
int hub_post(preview_hub *h, int slot, const char *name, const char *data);
/* Readers connected now: the daemon side renders camera frames only while
 * this is above 0. */
int hub_readers(preview_hub *h);

hub_reader *hub_reader_new(preview_hub *h);
void hub_reader_free(hub_reader *r);
/* Copies up to cap bytes of the stream into buf, waiting up to
 * keepalive_ms for something new (then a comment line).  Returns the bytes
 * copied, or -1 at the end of the stream (hub stopped). */
long hub_reader_read(hub_reader *r, char *buf, size_t cap, int keepalive_ms);

#endif
