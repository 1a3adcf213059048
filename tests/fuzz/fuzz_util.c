/* Helpers shared by the parser fuzz targets (see fuzz_util.h). */
#include "fuzz_util.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

static int input_fd = -1;
static char input_path[64];

int fuzz_load_from_file(const uint8_t *data, size_t size, fuzz_path_loader load, void *ctx)
{
	if (input_fd < 0) {
		input_fd = memfd_create("fuzz-input", MFD_CLOEXEC);
		if (input_fd < 0) {
			perror("fuzz: memfd_create");
			abort();
		}
		snprintf(input_path, sizeof(input_path), "/proc/self/fd/%d", input_fd);
	}
	if (ftruncate(input_fd, 0) != 0) {
		perror("fuzz: ftruncate");
		abort();
	}
	for (size_t done = 0; done < size;) {
		ssize_t n = pwrite(input_fd, data + done, size - done, (off_t)done);
		if (n <= 0) {
			perror("fuzz: pwrite");
			abort();
		}
		done += (size_t)n;
	}
	return load(input_path, ctx);
}

char *fuzz_text(const uint8_t *data, size_t size)
{
	char *text = malloc(size + 1);
	if (!text)
		abort();
	if (size)
		memcpy(text, data, size);
	text[size] = 0;
	return text;
}

void fuzz_fail(const char *target, const char *what, const mc_err *err)
{
	fprintf(stderr, "%s: %s%s%s\n", target, what, err ? "; message: " : "", err ? err->msg : "");
	abort();
}

void fuzz_check_refusal(const char *target, const char *origin, const mc_err *err)
{
	if (!err->msg[0])
		fuzz_fail(target, "input refused without a message", err);
	if (strncmp(err->msg, origin, strlen(origin)) != 0)
		fuzz_fail(target, "error message does not start with the input's name", err);
}

void fuzz_check_rig(const char *target, const mc_rig *rig)
{
	mc_err err = {{0}};
	if (rig->ncams < 1 || rig->ncams > MC_MAX_CAMERAS)
		fuzz_fail(target, "accepted a rig with no camera or too many", NULL);
	for (int i = 0; i < rig->ncams; i++)
		if (mc_camera_validate(&rig->cams[i], &err) != 0)
			fuzz_fail(target, "accepted a camera that mc_camera_validate refuses", &err);
	char *json = mc_rig_to_json(rig, &err);
	if (!json)
		fuzz_fail(target, "mc_rig_to_json failed", &err);
	mc_rig back;
	if (mc_rig_parse(json, "round-trip", &back, &err) != 0) {
		fprintf(stderr, "%s: the rig's JSON:\n%s\n", target, json);
		free(json);
		fuzz_fail(target, "an accepted rig written by mc_rig_to_json does not parse back", &err);
	}
	free(json);
	if (back.ncams != rig->ncams || back.kind != rig->kind)
		fuzz_fail(target, "the rig read back has other cameras or another kind", NULL);
	for (int i = 0; i < rig->ncams; i++) {
		const mc_camera *a = &rig->cams[i], *b = &back.cams[i];
		if (strcmp(a->name, b->name) != 0 || a->model != b->model || a->width != b->width ||
		    a->height != b->height)
			fuzz_fail(target, "a camera read back differs in name, model or size", NULL);
	}
}
