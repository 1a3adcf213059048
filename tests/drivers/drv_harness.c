/* drv_harness: a dlopen-based host for driver plugin tests. */
#include "drv_harness.h"

#include "base/mc_time.h"

#include <dlfcn.h>
#include <libgen.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

static const char *harness_config_get(void *ctx, const char *key)
{
	drv_harness *h = ctx;
	for (int i = 0; i < h->n_keys; i++)
		if (!strcmp(h->keys[i], key))
			return h->vals[i];
	return NULL;
}

static void harness_log(void *ctx, int level, const char *msg)
{
	static const char *const names[] = {"error", "warn", "info", "debug"};
	drv_harness *h = ctx;
	const char *lv = level >= 0 && level <= 3 ? names[level] : "?";
	pthread_mutex_lock(&h->log_lock);
	size_t len = strlen(h->log);
	snprintf(h->log + len, sizeof h->log - len, "%s: %s\n", lv, msg);
	pthread_mutex_unlock(&h->log_lock);
	if (!h->quiet)
		fprintf(stderr, "[driver %s] %s\n", lv, msg);
}

/* The folder holding the plugins. */
static void plugin_dir(char *out, size_t n)
{
	const char *env = getenv("MOCAP_DRIVER_DIR");
	if (env && *env) {
		snprintf(out, n, "%s", env);
		return;
	}
	char exe[PATH_MAX];
	ssize_t len = readlink("/proc/self/exe", exe, sizeof exe - 1);
	if (len <= 0) {
		snprintf(out, n, "build/drivers");
		return;
	}
	exe[len] = 0;
	snprintf(out, n, "%s/../../drivers", dirname(exe));
}

int drv_harness_load(drv_harness *h, const char *name, char *err, size_t errlen)
{
	memset(h, 0, sizeof *h);
	pthread_mutex_init(&h->log_lock, NULL);
	h->host.ctx = h;
	h->host.config_get = harness_config_get;
	h->host.log = harness_log;
	char dir[PATH_MAX], path[PATH_MAX + 64];
	plugin_dir(dir, sizeof dir);
	snprintf(path, sizeof path, "%s/mocap-driver-%s.so", dir, name);
	h->dl = dlopen(path, RTLD_NOW | RTLD_LOCAL);
	if (!h->dl) {
		snprintf(err, errlen, "dlopen %s: %s", path, dlerror());
		return -1;
	}
	mdrv_entry_fn entry = (mdrv_entry_fn)(uintptr_t)dlsym(h->dl, MDRV_ENTRY_SYMBOL);
	if (!entry) {
		snprintf(err, errlen, "%s: no symbol %s", path, MDRV_ENTRY_SYMBOL);
		dlclose(h->dl);
		h->dl = NULL;
		return -1;
	}
	h->drv = entry();
	if (!h->drv || h->drv->abi_version != MDRV_ABI_VERSION) {
		snprintf(err, errlen, "%s: ABI version mismatch", path);
		dlclose(h->dl);
		h->dl = NULL;
		return -1;
	}
	return 0;
}

void drv_harness_unload(drv_harness *h)
{
	/* The plugin stays mapped: libraries such as glib or OpenNI2 keep
	 * threads and atexit handlers that must not outlive their code. */
	h->dl = NULL;
	h->drv = NULL;
	pthread_mutex_destroy(&h->log_lock);
}

void drv_harness_set(drv_harness *h, const char *key, const char *val)
{
	for (int i = 0; i < h->n_keys; i++) {
		if (strcmp(h->keys[i], key))
			continue;
		if (val) {
			snprintf(h->vals[i], sizeof h->vals[i], "%s", val);
		} else {
			h->n_keys--;
			memmove(h->keys[i], h->keys[h->n_keys], sizeof h->keys[i]);
			memmove(h->vals[i], h->vals[h->n_keys], sizeof h->vals[i]);
		}
		return;
	}
	if (!val || h->n_keys == DRV_HARNESS_MAX_KEYS)
		return;
	snprintf(h->keys[h->n_keys], sizeof h->keys[0], "%s", key);
	snprintf(h->vals[h->n_keys], sizeof h->vals[0], "%s", val);
	h->n_keys++;
}

void drv_harness_clear(drv_harness *h)
{
	h->n_keys = 0;
}

int drv_harness_logged(drv_harness *h, const char *needle)
{
	pthread_mutex_lock(&h->log_lock);
	int found = strstr(h->log, needle) != NULL;
	pthread_mutex_unlock(&h->log_lock);
	return found;
}

void *drv_harness_open_start(drv_harness *h, char *err, size_t errlen)
{
	void *dev = h->drv->open(&h->host, err, errlen);
	if (!dev)
		return NULL;
	if (h->drv->start(dev, err, errlen) != MDRV_OK) {
		h->drv->close(dev);
		return NULL;
	}
	return dev;
}

int drv_harness_frame(drv_harness *h, void *dev, mdrv_frame *f, void *buf, size_t cap, int timeout_ms, char *err,
		      size_t errlen)
{
	memset(f, 0, sizeof *f);
	f->data = buf;
	f->capacity = cap;
	err[0] = 0;
	return h->drv->next_frame(dev, f, timeout_ms, err, errlen);
}

unsigned long long drv_harness_now_ns(void)
{
	return mc_now_ns();
}
