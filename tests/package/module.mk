# The Debian packages (debian/, docs/PACKAGING.md): tests/package-test.sh
# builds them with dpkg-buildpackage in a copy of the tree, runs lintian,
# installs them with apt-get, runs the installed programs and purges them.
# Root only (it skips otherwise); about 2 minutes on 2 cores, most of it
# the package build, so it gets a longer timeout than run-tests.sh's default.
CHECKS += check-package
.PHONY: check-package
check-package:
	@mkdir -p $(BUILD)/tests
	MOCAP_TEST_TIMEOUT=$${MOCAP_TEST_TIMEOUT:-1200} tests/run-tests.sh $(BUILD) tests/package-test.sh
