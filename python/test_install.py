"""`pip install ./python` into a fresh virtual environment gives an importable
mocap of the same version, with no dependencies.  Offline: the venv sees the
system's setuptools (--system-site-packages) and pip builds without build
isolation, as docs/PROTOCOL.md says to install it."""
import json
import os
import shutil
import subprocess
import sys

import pytest

import mocap
from conftest import HERE

CHECK = """
import importlib.metadata as md, json, mocap, mocap.aio
print(json.dumps({"version": mocap.__version__, "file": mocap.__file__, "dist": md.version("mocap"),
                  "requires": md.requires("mocap"), "aio": mocap.aio.connect is mocap.connect}))
"""


def test_pip_install(tmp_path):
    python = "/usr/bin/python3" if os.access("/usr/bin/python3", os.X_OK) else sys.executable
    for module in ("venv", "pip", "setuptools"):
        if subprocess.run([python, "-c", "import " + module], capture_output=True).returncode:
            pytest.skip("%s has no %s module (make deps)" % (python, module))
    # A copy of python/ as it is in the work tree, so that the build's
    # leftovers (build/, mocap.egg-info/) do not land in the sources.
    shutil.copytree(HERE, str(tmp_path / "python"),
                    ignore=shutil.ignore_patterns("__pycache__", ".pytest_cache", "build", "*.egg-info"))
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "PIP_", "VIRTUAL_ENV"))}
    env.update(PIP_NO_INDEX="1", PIP_DISABLE_PIP_VERSION_CHECK="1", PYTHONDONTWRITEBYTECODE="1")

    def run(*args):
        r = subprocess.run(args, cwd=str(tmp_path), env=env, capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, "%s\n%s%s" % (" ".join(args), r.stdout, r.stderr)
        return r.stdout
    venv = tmp_path / "venv"
    run(python, "-m", "venv", "--system-site-packages", "--without-pip", str(venv))
    vpython = str(venv / "bin" / "python")
    run(vpython, "-m", "pip", "install", "--no-build-isolation", "--no-deps", "./python")
    got = json.loads(run(vpython, "-c", CHECK))
    assert got["version"] == got["dist"] == mocap.__version__
    assert got["file"].startswith(str(venv)), got["file"]  # the installed copy, not the sources
    assert not got["requires"]  # standard library only
    assert got["aio"]
    run(vpython, "-m", "pip", "uninstall", "-y", "mocap")
