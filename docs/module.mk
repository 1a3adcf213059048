# Man pages: docs/man/NAME.SECTION.scd, written in scdoc (Debian's scdoc),
# built into $(BUILD)/man/NAME.SECTION and installed under DATADIR/man.

MAN_SRC := $(wildcard docs/man/*.scd)
MANS := $(patsubst docs/man/%.scd,$(BUILD)/man/%,$(MAN_SRC))
SCDOC ?= scdoc

ifneq ($(shell command -v $(SCDOC) 2>/dev/null),)
all: $(MANS)
INSTALL_MANS := $(MANS)
endif

$(BUILD)/man/%: docs/man/%.scd
	@mkdir -p $(@D)
	$(SCDOC) < $< > $@.tmp && mv $@.tmp $@

.PHONY: install-man uninstall-man
install: install-man
install-man: $(INSTALL_MANS)
	@for m in $(INSTALL_MANS); do s=$${m##*.}; install -d $(DESTDIR)$(DATADIR)/man/man$$s && \
		install -m 644 $$m $(DESTDIR)$(DATADIR)/man/man$$s/ || exit 1; done
uninstall: uninstall-man
uninstall-man:
	rm -f $(foreach m,$(MANS),$(DESTDIR)$(DATADIR)/man/man$(subst .,,$(suffix $(m)))/$(notdir $(m)))
