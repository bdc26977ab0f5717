"""`pip install ./python` (python/pyproject.toml, the in-tree backend): into a fresh venv, with no
index (nothing may be downloaded), a wheel of the build's package that imports outside the source
tree and gives the build tree's values; `-e` names the build tree; a missing build is a clear error."""

import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import btfstudio
from conftest import SOURCE, btfsim, scene

BUILD = pathlib.Path(btfstudio.__file__).resolve().parents[2]  # BUILD/python/btfstudio/__init__.py


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    raw = tmp_path_factory.mktemp("btf") / "spheres.btf"
    btfsim("simulate", scene("spheres"), "-o", raw, "--texels", "4", "--dirs", "4x8", "--spp", "1",
           "-q")
    return {"raw": raw}


def venv(path):
    subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", str(path)], check=True)
    return path / "bin" / "python"


def pip_install(py, *args, env=None):
    e = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    e.update(env or {})
    return subprocess.run([str(py), "-m", "pip", "install", "--no-index", "--no-cache-dir",
                           "--disable-pip-version-check", *args], capture_output=True, text=True,
                          env=e, cwd=SOURCE)


def run_in(py, code, cwd):
    e = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    p = subprocess.run([str(py), "-c", code], capture_output=True, text=True, env=e, cwd=cwd)
    assert p.returncode == 0, p.stderr
    return p.stdout.strip().splitlines()


PROBE = """
import btfstudio, numpy as np, sys
b = btfstudio.open(sys.argv[1] if len(sys.argv) > 1 else {path!r})
print(btfstudio.__file__)
print(repr(b.slice(view=(30, 90), light=(45, 0)).astype(float).sum()))
"""


def test_pip_install_wheels_the_build_and_it_imports_outside_the_tree(tmp_path, files):
    py = venv(tmp_path / "v")
    p = pip_install(py, str(SOURCE / "python"), env={"BTF_BUILD_DIR": str(BUILD)})
    assert p.returncode == 0, p.stdout + p.stderr
    where, total = run_in(py, PROBE.format(path=str(files["raw"])), tmp_path)
    assert pathlib.Path(where).is_relative_to(tmp_path / "v"), where
    want = btfstudio.open(files["raw"]).slice(view=(30, 90), light=(45, 0)).astype(float).sum()
    assert float(total) == want
    # The wheel carries the package's files and the extension, listed in its RECORD.
    site = pathlib.Path(where).parent
    assert {"__init__.py", "mitsuba.py"} <= {f.name for f in site.glob("*.py")}
    assert list(site.glob("_core*.so"))
    assert (site / "libbtf_oiio.so").is_file()  # the OpenImageIO module the engine loads
    # Uninstalled cleanly from its RECORD.
    u = subprocess.run([str(py), "-m", "pip", "uninstall", "-y", "btfstudio"], capture_output=True,
                       text=True)
    assert u.returncode == 0 and not site.exists(), u.stdout + u.stderr


def test_editable_install_names_the_build_tree(tmp_path, files):
    py = venv(tmp_path / "v")
    p = pip_install(py, "-e", str(SOURCE / "python"), env={"BTF_BUILD_DIR": str(BUILD)})
    assert p.returncode == 0, p.stdout + p.stderr
    where, _ = run_in(py, PROBE.format(path=str(files["raw"])), tmp_path)
    assert pathlib.Path(where).resolve() == pathlib.Path(btfstudio.__file__).resolve()


def test_a_missing_build_is_a_clear_error(tmp_path):
    py = venv(tmp_path / "v")
    p = pip_install(py, str(SOURCE / "python"), env={"BTF_BUILD_DIR": str(tmp_path / "nowhere")})
    assert p.returncode != 0
    out = p.stdout + p.stderr
    assert "is missing" in out and "btf_python" in out, out
    assert not list((tmp_path / "v").glob("lib/python*/site-packages/btfstudio"))
