/* mc_file: reading a whole file, for every loader that does, and writing
 * one atomically, for every saver.
 *
 * Refuses what is not a regular file (a directory, /dev/zero, a FIFO) and
 * anything larger than the caller's bound before allocating, so that no
 * path given in a config can make a loader allocate without limit or read
 * for ever (issue: "a directory as a BVH path" mallocs 2^63 bytes). */
#ifndef MC_FILE_H
#define MC_FILE_H

#include "base/mc_error.h"

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

/* Reads path into *data (malloc'ed, with a NUL byte after the *bytes read,
 * so that text can be parsed in place).  Errors name the file: "x.bvh: not
 * a regular file (a directory)", "x.jpg: 70000000 bytes, more than the
 * 67108864 accepted". */
int mc_file_read(const char *path, size_t max_bytes, uint8_t **data, size_t *bytes, mc_err *err);

/* Opens path for reading ("rb") when it is a regular file; a FIFO, a
 * device or a directory is refused at once, without waiting on it
 * ("x.mcr: not a regular file (a FIFO)").  NULL with err naming the file. */
FILE *mc_file_open_regular(const char *path, mc_err *err);
/* -1 with err when path exists and is not a regular file, else 0 (a
 * missing file is left to the caller's own open to report). */
int mc_file_refuse_special(const char *path, mc_err *err);

/* Writes n bytes to path through a temporary file beside it, synced and
 * renamed into place, and syncs the directory: a crash leaves the old file
 * or the new one, whole.  Errors name the file. */
int mc_file_write_atomic(const char *path, const void *data, size_t n, mc_err *err);

/* For command-line programs writing an output file: fopen(path, "w"), or
 * exit 1 with "prog: path: reason"; and its fclose, exiting 1 with "prog:
 * path: write error" when any write or the close failed (a full disk). */
FILE *mc_file_create_or_exit(const char *prog, const char *path);
void mc_file_close_or_exit(const char *prog, FILE *f, const char *path);

#endif
