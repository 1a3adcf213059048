# Read after the project's Makefile by debian/rules (make -f Makefile -f
# debian/build.mk): builds what `make install` installs, without the test
# programs of `make all`.  Anything missed here is built by `make install`.
.PHONY: deb-build
deb-build: $(INSTALLED) $(INSTALL_MANS) $(IPC_SO) $(IPC_PC)
