"""Fixtures of the Python package's tests: small BTFs simulated once per session by btfsim.

ctest sets BTF_BTFSIM (the btfsim binary), BTF_SOURCE_DIR and PYTHONPATH (build/python).
"""

import os
import pathlib
import subprocess

import pytest

SOURCE = pathlib.Path(os.environ.get("BTF_SOURCE_DIR", pathlib.Path(__file__).parents[2]))
BTFSIM = os.environ.get("BTF_BTFSIM", str(SOURCE / "build" / "app" / "btfsim"))


def btfsim(*args, check=True):
    """Runs btfsim; returns (exit code, stdout, stderr)."""
    p = subprocess.run([BTFSIM, *map(str, args)], capture_output=True, text=True)
    if check and p.returncode != 0:
        raise AssertionError(f"btfsim {' '.join(map(str, args))} failed: {p.stderr}")
    return p.returncode, p.stdout, p.stderr


def scene(name):
    return str(SOURCE / "resources" / "scenes" / f"{name}.json")


@pytest.fixture(scope="session")
def files(tmp_path_factory):
    """A raw brick store 8 x 6 texels at 4 x 8 directions, and it compressed by every codec and
    as a pyramid (neural with few training steps: its decoder, not its accuracy, is under test):
    {kind: path}."""
    d = tmp_path_factory.mktemp("btfs")
    raw = d / "brick.btf"
    btfsim("simulate", scene("brick"), "-o", raw, "--texels", "8x6", "--dirs", "4x8", "--spp", "2",
           "-q")
    out = {"raw": raw}
    for codec in ("nmf", "svd", "perview", "lpca", "tensor"):
        p = d / f"brick_{codec}.cbtf"
        btfsim("compress", raw, "-o", p, "--codec", codec, "-q")
        out[codec] = p
    p = d / "brick_neural.cbtf"
    btfsim("compress", raw, "-o", p, "--codec", "neural", "--neural-steps", "300", "-q")
    out["neural"] = p
    p = d / "brick_mip.cbtf"
    btfsim("compress", raw, "-o", p, "--codec", "tensor", "--mip", "-q")
    out["mip"] = p
    return out
