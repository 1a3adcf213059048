# preview/: mocap-preview, a live view of mocapd in a web browser (HTTP with
# libmicrohttpd, Server-Sent Events, three.js from libjs-three); a client of
# the daemon; docs/PREVIEW.md.  The page is preview/www, installed into
# $(DATADIR)/mocapd/preview.  test_preview checks the HTTP side (routes, the
# token, the events, the daemon going away) with mocapd on the bundled
# clip; test_preview_browser loads the page in headless Chromium through
# the DevTools protocol and checks its screenshots.

PREVIEW_OBJ := $(patsubst preview/%.c,$(BUILD)/preview/%.o,$(filter-out preview/mocap-preview.c,$(wildcard preview/*.c)))
PREVIEW_LIB := $(BUILD)/libmocappreview.a
MOCAP_PREVIEW := $(BUILD)/bin/mocap-preview
PREVIEW_TESTS := $(patsubst preview/tests/%.c,$(BUILD)/preview/tests/%,$(wildcard preview/tests/test_*.c))
PREVIEW_MHD_CFLAGS := $(shell $(PKG_CONFIG) --cflags libmicrohttpd 2>/dev/null)
PREVIEW_MHD_LIBS := $(or $(shell $(PKG_CONFIG) --libs libmicrohttpd 2>/dev/null),-lmicrohttpd)
PREVIEW_LINK := $(PREVIEW_LIB) $(BUILD)/libmocap.a $(CORE_LIB) $(CORE_LIBS) $(PREVIEW_MHD_LIBS)
PREVIEW_LINK_DEPS := $(PREVIEW_LIB) $(BUILD)/libmocap.a $(CORE_LIB)
PREVIEW_WWW_DIR ?= $(DATADIR)/mocapd/preview

DEB_PACKAGES += libmicrohttpd-dev libjs-three chromium curl
LIBS += $(PREVIEW_LIB)
BINS += $(MOCAP_PREVIEW)
TESTS += $(PREVIEW_TESTS)
BENCHES += bench-preview

$(BUILD)/preview/%.o: CPPFLAGS += -Ipreview -Iipc $(PREVIEW_MHD_CFLAGS)

$(PREVIEW_LIB): $(PREVIEW_OBJ)
	@rm -f $@
	ar rcs $@ $^

$(MOCAP_PREVIEW): preview/mocap-preview.c $(PREVIEW_LINK_DEPS) $(INSTALL_PATHS_H)
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) -Ipreview -Iipc $(PREVIEW_MHD_CFLAGS) $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(PREVIEW_LINK)

# The tests run mocapd on the bundled clip (files driver) and mocap-preview.
$(BUILD)/preview/tests/%: preview/tests/%.c $(PREVIEW_LINK_DEPS) \
		| $(MOCAP_PREVIEW) $(BUILD)/bin/mocapd $(BUILD)/drivers/mocap-driver-files.so
	@mkdir -p $(@D) $(BUILD)/tests
	$(CC) $(CPPFLAGS) -Ipreview -Iipc -Itests $(CFLAGS) -MMD -MP $< -o $@ $(LDFLAGS) $(PREVIEW_LINK)

# The daemon's tracking time with and without one open page (docs/BENCHMARKS.md).
.PHONY: bench-preview
bench-preview: $(MOCAP_PREVIEW) $(BUILD)/bin/mocapd $(BUILD)/bin/mocapctl $(BUILD)/drivers/mocap-driver-files.so
	/usr/bin/python3 preview/bench_preview.py $(BUILD)

.PHONY: install-preview uninstall-preview
install: install-preview
install-preview:
	install -d $(DESTDIR)$(PREVIEW_WWW_DIR)
	install -m 644 preview/www/index.html preview/www/preview.js preview/www/preview.css $(DESTDIR)$(PREVIEW_WWW_DIR)/

uninstall: uninstall-preview
uninstall-preview:
	rm -rf $(DESTDIR)$(PREVIEW_WWW_DIR)
