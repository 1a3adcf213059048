/* Helpers shared by the parser fuzz targets (tests/fuzz/module.mk). */
#ifndef FUZZ_UTIL_H
#define FUZZ_UTIL_H

#include "base/mc_error.h"
#include "geom/mc_rig.h"

#include <stddef.h>
#include <stdint.h>

/* libFuzzer's entry point, declared once for every target. */
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* The loaders that take a path (calib.json, cameras.json,
 * calib_results.txt) read the input from a file: it is written to a
 * memfd, and the loader is handed "/proc/self/fd/N", which opens it afresh
 * as a regular file.  Nothing is left on disk, even after a crash.
 * Returns what load returned. */
typedef int (*fuzz_path_loader)(const char *path, void *ctx);
int fuzz_load_from_file(const uint8_t *data, size_t size, fuzz_path_loader load, void *ctx);

/* The input as a NUL-terminated string (malloc'ed; free it), for the
 * parsers that take text.  Bytes after an embedded NUL are not seen by
 * such a parser, as they are not by the loaders that read files (which
 * refuse a NUL byte). */
char *fuzz_text(const uint8_t *data, size_t size);

/* Aborts, so that libFuzzer records the input, when a parser broke one of
 * its documented promises (e.g. refused an input without saying why). */
void fuzz_fail(const char *target, const char *what, const mc_err *err) __attribute__((noreturn));

/* A refused input must come with a message that names where it came from
 * (`origin`: the file name the parser was given). */
void fuzz_check_refusal(const char *target, const char *origin, const mc_err *err);

/* What every rig a loader accepted must satisfy: 1..MC_MAX_CAMERAS
 * cameras that pass mc_camera_validate, and the rig JSON the daemon sends
 * its clients (mc_rig_to_json) parses back (mc_rig_parse) to the same
 * cameras: names, models and sizes. */
void fuzz_check_rig(const char *target, const mc_rig *rig);

#endif
